//! Running long calls: without the GIL, on the requested number of threads, interruptible by
//! Ctrl-C.
//!
//! A call that may take long runs on a helper thread while the calling (Python) thread waits
//! without the GIL, waking every [`POLL`] to take the GIL briefly and run Python's signal
//! handlers (`PyErr_CheckSignals`). When a handler raises (Ctrl-C: `KeyboardInterrupt`), the
//! work is told to stop through a flag it checks between chunks, the helper is joined, and the
//! handler's exception is raised. Work that cannot check the flag (a render, a phase of a
//! build) finishes first; the exception is raised when it returns.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, OnceLock};
use std::time::Duration;

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use rayon::ThreadPool;

use crate::errors;

/// How often a waiting call checks for signals.
pub const POLL: Duration = Duration::from_millis(50);

/// Work with fewer items than this runs on the calling thread (still without the GIL): the
/// helper thread costs tens of microseconds, and such calls end in milliseconds.
pub const INLINE_ITEMS: usize = 16 * 1024;

/// The flag a long call checks between its chunks.
pub struct Cancel(AtomicBool);

impl Cancel {
    /// Whether the caller asked the work to stop.
    #[inline]
    pub fn is_set(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// What work returns when it saw the flag and stopped early.
#[derive(Debug)]
pub struct Cancelled;

/// Pools kept for reuse ([`pool`]): a loop alternating two thread counts reuses both.
const CACHED_POOLS: usize = 2;

/// The pool of `threads=n` calls. A pool costs a few milliseconds to start, so the last
/// [`CACHED_POOLS`] are kept for the next calls; an older one is dropped (its threads end when
/// no call runs in it any more). Before issue 32 every distinct count got a pool kept forever:
/// calls with threads=1…40 left 822 threads alive.
fn pool(threads: usize) -> PyResult<Arc<ThreadPool>> {
    static POOLS: Mutex<Vec<(usize, Arc<ThreadPool>)>> = Mutex::new(Vec::new());
    let mut pools = POOLS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(i) = pools.iter().position(|(n, _)| *n == threads) {
        // Most recently used last.
        let entry = pools.remove(i);
        let p = entry.1.clone();
        pools.push(entry);
        return Ok(p);
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("sdfmo-{i}"))
        .build()
        .map_err(|e| {
            PyRuntimeError::new_err(format!("cannot start {threads} worker threads: {e}"))
        })?;
    let p = Arc::new(p);
    if pools.len() == CACHED_POOLS {
        pools.remove(0);
    }
    pools.push((threads, p.clone()));
    Ok(p)
}

/// The cores this process may run on (`std::thread::available_parallelism`: CPU affinity and
/// cgroup quotas included), at least 1; read once.
pub fn available_cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Checks a `threads` argument: `None` (all cores) or at least 1, clamped to
/// [`available_cores`]: the results are the same for any count, so more threads than cores
/// only cost (`threads=10**6` spent a minute starting threads before issue 32).
pub fn check_threads(threads: Option<i64>) -> PyResult<Option<usize>> {
    match threads {
        None => Ok(None),
        Some(n) if n >= 1 => Ok(Some(
            usize::try_from(n)
                .map_or(usize::MAX, |n| n)
                .min(available_cores()),
        )),
        Some(n) => Err(PyValueError::new_err(format!(
            "threads must be None (all cores) or at least 1, got {n}"
        ))),
    }
}

/// Runs `f` on `threads` workers (rayon's global pool, one thread per core, for `None`).
fn in_threads<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> PyResult<R> {
    match threads {
        None => Ok(f()),
        Some(n) => Ok(pool(n)?.install(f)),
    }
}

/// Runs `work` without the GIL on `threads` workers; `items` (the number of points, pixels…)
/// decides whether it runs inline or on a helper thread that Ctrl-C can interrupt (see the
/// module docs). `work` returns `Err(Cancelled)` when it saw the flag; the pending Python
/// exception (`KeyboardInterrupt`) is raised then.
pub fn run<T: Send>(
    py: Python<'_>,
    threads: Option<usize>,
    items: usize,
    work: impl FnOnce(&Cancel) -> Result<T, Cancelled> + Send,
) -> PyResult<T> {
    let cancel = Cancel(AtomicBool::new(false));
    if items < INLINE_ITEMS {
        let r = py.detach(|| in_threads(threads, || work(&cancel)))?;
        py.check_signals()?;
        return r.map_err(|Cancelled| PyRuntimeError::new_err("cancelled without a signal"));
    }
    // The helper's "finished" flag: a mutex and a condition variable (both `Sync`, so the
    // waiting thread can hold them without the GIL).
    let done = (Mutex::new(false), Condvar::new());
    let wait = |timeout: Option<Duration>| -> bool {
        let guard = done.0.lock().unwrap_or_else(|e| e.into_inner());
        let guard = match timeout {
            Some(t) => {
                done.1
                    .wait_timeout_while(guard, t, |finished| !*finished)
                    .unwrap_or_else(|e| e.into_inner())
                    .0
            }
            None => done
                .1
                .wait_while(guard, |finished| !*finished)
                .unwrap_or_else(|e| e.into_inner()),
        };
        *guard
    };
    let result = std::thread::scope(|s| {
        let cancel = &cancel;
        let done = &done;
        // Spawned fallibly: under an address-space limit the helper's stack may not fit (a
        // panic of `spawn` before issue 32).
        let spawned = std::thread::Builder::new()
            .name("sdfmo-call".into())
            .spawn_scoped(s, move || {
                // Set the flag even when the work panics.
                struct Finish<'a>(&'a (Mutex<bool>, Condvar));
                impl Drop for Finish<'_> {
                    fn drop(&mut self) {
                        *self.0 .0.lock().unwrap_or_else(|e| e.into_inner()) = true;
                        self.0 .1.notify_all();
                    }
                }
                let _finish = Finish(done);
                in_threads(threads, || work(cancel))
            });
        let handle = match spawned {
            Ok(h) => h,
            Err(e) if e.kind() == std::io::ErrorKind::OutOfMemory => {
                return Err(errors::memory_error(format!("cannot start a thread: {e}")))
            }
            Err(e) => {
                return Err(PyRuntimeError::new_err(format!(
                    "cannot start a thread: {e}"
                )))
            }
        };
        let mut interrupted = None;
        while !py.detach(|| wait(Some(POLL))) {
            if let Err(e) = py.check_signals() {
                cancel.0.store(true, Ordering::Relaxed);
                interrupted = Some(e);
                // Wait for the work to notice (between two chunks).
                py.detach(|| wait(None));
                break;
            }
        }
        let joined = py.detach(|| handle.join());
        Ok((joined, interrupted))
    })?;
    match result {
        (_, Some(e)) => Err(e),
        (Ok(Ok(Ok(v))), None) => Ok(v),
        (Ok(Ok(Err(Cancelled))), None) => {
            Err(PyRuntimeError::new_err("cancelled without a signal"))
        }
        (Ok(Err(e)), None) => Err(e),
        (Err(panic), None) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error in sdfmo (please report it): {what}"
            )))
        }
    }
}

/// Makes sure `bytes` of address space can be allocated now (reserved and released at once,
/// never touched: it costs a mapping, not memory), else `MemoryError` naming `what`. Work
/// whose allocations cannot all be made fallible (a mesh's welding, a library's arrays) asks
/// first for an estimate of its peak, so that under an address-space limit it fails here with
/// an exception instead of aborting the interpreter halfway.
pub fn ensure_headroom(bytes: u64, what: &str) -> PyResult<()> {
    let fail = || {
        errors::memory_error(format!(
            "{what} needs about {bytes} bytes of memory, which cannot be allocated"
        ))
    };
    let n = usize::try_from(bytes).map_err(|_| fail())?;
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(n).map_err(|_| fail())
}

/// Points per chunk of a batch query: large enough to keep every worker busy and sort the
/// points well (Morton order), small enough that Ctrl-C answers within a fraction of a second
/// and the scratch memory stays a few megabytes.
pub fn chunk_len() -> usize {
    (rayon::current_num_threads() * 8192).clamp(65536, 1 << 20)
}
