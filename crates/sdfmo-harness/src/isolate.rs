//! Failure isolation: each model of a manifest sweep runs in a child process of this same
//! binary (`sdfmo sweep MESH --isolated-model NAME …`), with a wall-time limit and an
//! address-space limit.
//!
//! Why a process rather than cancelling inside this one: a model can fail in ways no in-process
//! cancellation reaches. A hostile file may drive a loader or the BVH into a long loop that
//! checks no flag, a stack overflow aborts the whole process, an allocation that fails ends it
//! (the CLI's allocator exits on out-of-memory), and a bug panics. A child is killed at its
//! deadline whatever it is doing (SIGKILL), its memory is capped by the kernel (`RLIMIT_AS`) and
//! its crash is one failed model in the ledger, while the shard goes on. The cost is a process
//! start and a mesh load per model, milliseconds against the seconds a model takes (measured in
//! docs/results/dataset.md). The child dies with the shard (`PR_SET_PDEATHSIG`), so a killed
//! shard leaves no orphan writing into its folder.

use std::ffi::OsString;
use std::io::Read;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::error::{HarnessError, Result};

/// Most bytes of a child's stdout kept (its one JSON line).
const MAX_STDOUT: u64 = 64 << 20;
/// Most bytes of a child's stderr kept (its tail: the error line is the last).
const STDERR_TAIL: usize = 16 << 10;

/// What one child process did.
#[derive(Debug)]
pub struct ChildRun {
    /// Its stdout when it exited with 0; else its error line.
    pub result: std::result::Result<Vec<u8>, String>,
    /// Wall time from spawn to exit (ms).
    pub wall_ms: f64,
    /// Peak resident set size the kernel measured (bytes).
    pub peak_rss_bytes: Option<u64>,
}

/// Address space a child may reserve beyond twice its build budget: thread stacks, allocator
/// arenas, the binary (the kernel's cap is `2 · budget + ADDRESS_SPACE_SLACK`).
pub const ADDRESS_SPACE_SLACK: u64 = 1 << 30;

/// The address-space cap (`RLIMIT_AS`) of a model's process for a build budget of `budget`
/// bytes: twice the budget plus [`ADDRESS_SPACE_SLACK`], but never more than the machine has
/// ([`machine_memory`]: with more, the kernel's OOM killer acts before the cap) nor more than
/// the limit this process runs under itself (a non-root user may not raise `RLIMIT_AS` above
/// its hard limit: every model's process failed to start, "Operation not permitted"). `None`:
/// no cap known to apply.
pub fn address_space_cap(budget: Option<u64>) -> Option<u64> {
    clamp_cap(budget, machine_memory(), inherited_address_space())
}

/// [`address_space_cap`] from its inputs: the wanted cap, clamped to `machine` and `inherited`.
fn clamp_cap(budget: Option<u64>, machine: Option<u64>, inherited: Option<u64>) -> Option<u64> {
    let wanted = budget.map(|b| b.saturating_mul(2).saturating_add(ADDRESS_SPACE_SLACK));
    [wanted, machine, inherited].into_iter().flatten().min()
}

/// The memory this machine (or container) has: the physical memory, or the cgroup's memory
/// limit when lower (a Kubernetes pod's `resources.limits.memory`; version 2's `memory.max`,
/// or version 1's `memory.limit_in_bytes`, as mounted in the process's own namespace).
pub fn machine_memory() -> Option<u64> {
    let cgroup = [
        "/sys/fs/cgroup/memory.max",
        "/sys/fs/cgroup/memory/memory.limit_in_bytes",
    ]
    .iter()
    .filter_map(|p| std::fs::read_to_string(p).ok())
    .filter_map(|t| t.trim().parse::<u64>().ok())
    // "max" (no limit) does not parse; version 1 says "no limit" with a number near 2^63.
    .filter(|&b| b < 1 << 62)
    .min();
    [sdf_multioctree::build::physical_memory(), cgroup]
        .into_iter()
        .flatten()
        .min()
}

/// The address-space limit this process runs under (the soft limit, which is at most the hard
/// one), or `None` when unlimited.
pub fn inherited_address_space() -> Option<u64> {
    #[cfg(unix)]
    {
        let mut lim = libc::rlimit {
            rlim_cur: 0,
            rlim_max: 0,
        };
        // SAFETY: getrlimit writes the one valid, exclusive struct passed.
        if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut lim) } != 0 {
            return None;
        }
        // `rlim_t` is u64 on Linux, not on every Unix.
        #[allow(clippy::unnecessary_cast)]
        let (soft, hard) = (
            (lim.rlim_cur != libc::RLIM_INFINITY).then_some(lim.rlim_cur as u64),
            (lim.rlim_max != libc::RLIM_INFINITY).then_some(lim.rlim_max as u64),
        );
        [soft, hard].into_iter().flatten().min()
    }
    #[cfg(not(unix))]
    None
}

/// Sets this process's address-space limit (`RLIMIT_AS`, soft and hard) to `bytes`. Calls only
/// `setrlimit` and allocates nothing, so it may run between fork and exec
/// (`CommandExt::pre_exec`): the cap of a model's process, and the tests' lower inherited limit.
///
/// # Errors
///
/// The operating system's error (a limit above the hard limit without the right to raise it).
#[cfg(unix)]
pub fn limit_address_space(bytes: u64) -> std::io::Result<()> {
    let lim = libc::rlimit {
        rlim_cur: bytes as libc::rlim_t,
        rlim_max: bytes as libc::rlim_t,
    };
    // SAFETY: setrlimit reads the one valid struct passed.
    if unsafe { libc::setrlimit(libc::RLIMIT_AS, &lim) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// Limits of one child.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Killed after this long.
    pub timeout: Option<Duration>,
    /// Address-space limit (`RLIMIT_AS`), bytes.
    pub address_space: Option<u64>,
}

/// Runs this binary with `args` under `limits`.
pub fn run_child(args: &[OsString], limits: Limits) -> Result<ChildRun> {
    let exe = std::env::current_exe().map_err(HarnessError::NoExecutable)?;
    let mut cmd = Command::new(exe);
    cmd.args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    #[cfg(target_os = "linux")]
    {
        use std::os::unix::process::CommandExt;
        let address_space = limits.address_space;
        // SAFETY: the closure runs in the child between fork and exec and calls only
        // async-signal-safe functions (prctl, setrlimit), allocating nothing.
        unsafe {
            cmd.pre_exec(move || {
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL, 0, 0, 0) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                match address_space {
                    Some(bytes) => limit_address_space(bytes),
                    None => Ok(()),
                }
            });
        }
    }
    let start = Instant::now();
    let mut child = cmd.spawn().map_err(HarnessError::Spawn)?;
    let pid = child.id();
    let mut stdout = child.stdout.take().expect("piped stdout");
    let mut stderr = child.stderr.take().expect("piped stderr");
    let out = std::thread::spawn(move || {
        let mut buf = Vec::new();
        let _ = (&mut stdout).take(MAX_STDOUT).read_to_end(&mut buf);
        // Drain the rest so the child never blocks on a full pipe.
        let _ = std::io::copy(&mut stdout, &mut std::io::sink());
        buf
    });
    let err = std::thread::spawn(move || {
        let mut tail: Vec<u8> = Vec::new();
        let mut chunk = [0u8; 8192];
        while let Ok(n) = stderr.read(&mut chunk) {
            if n == 0 {
                break;
            }
            tail.extend_from_slice(&chunk[..n]);
            if tail.len() > 2 * STDERR_TAIL {
                tail.drain(..tail.len() - STDERR_TAIL);
            }
        }
        tail
    });
    // A waiter thread reaps the child (wait4, for its peak memory); this thread waits for it
    // with the deadline, without polling.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(wait(pid));
    });
    let mut timed_out = false;
    let status = match limits.timeout {
        Some(t) => match rx.recv_timeout(t) {
            Ok(s) => s,
            Err(_) => {
                timed_out = true;
                // SAFETY: kill(2) on the child's pid, which the waiter has not reaped yet (it
                // has sent nothing), so the pid still names our child.
                unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) };
                rx.recv().unwrap_or(Wait::Unknown)
            }
        },
        None => rx.recv().unwrap_or(Wait::Unknown),
    };
    drop(child);
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let stdout = out.join().unwrap_or_default();
    let stderr = err.join().unwrap_or_default();
    let last_line = || {
        String::from_utf8_lossy(&stderr)
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| !l.is_empty())
            .map(|l| {
                let l = l.strip_prefix("sdfmo: error: ").unwrap_or(l);
                l.chars().take(400).collect::<String>()
            })
    };
    let (result, peak) = match status {
        _ if timed_out => (
            Err(format!(
                "timed out after {:.0} s (--model-timeout)",
                limits.timeout.unwrap_or_default().as_secs_f64()
            )),
            None,
        ),
        Wait::Exited(0, peak) => (Ok(stdout), peak),
        Wait::Exited(code, peak) => (
            Err(last_line().unwrap_or_else(|| format!("exited with code {code}"))),
            peak,
        ),
        Wait::Signaled(sig, peak) => (
            Err(match last_line() {
                Some(l) => format!("killed by signal {sig}: {l}"),
                None => format!("killed by signal {sig}"),
            }),
            peak,
        ),
        Wait::Unknown => (Err("its process could not be waited for".to_owned()), None),
    };
    Ok(ChildRun {
        result,
        wall_ms,
        peak_rss_bytes: peak,
    })
}

/// How a child ended, with its peak resident memory.
enum Wait {
    Exited(i32, Option<u64>),
    Signaled(i32, Option<u64>),
    Unknown,
}

/// Reaps `pid` with wait4, retrying on EINTR.
fn wait(pid: u32) -> Wait {
    let mut status: libc::c_int = 0;
    // SAFETY: an all-zero rusage is a valid value of the plain C struct.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    loop {
        // SAFETY: wait4 writes only to the two valid, exclusive pointers passed.
        let r = unsafe { libc::wait4(pid as libc::pid_t, &mut status, 0, &mut usage) };
        if r == pid as libc::pid_t {
            break;
        }
        if r == -1 && std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted {
            continue;
        }
        return Wait::Unknown;
    }
    // ru_maxrss is in kilobytes on Linux.
    let peak = u64::try_from(usage.ru_maxrss).ok().map(|kb| kb * 1024);
    if libc::WIFEXITED(status) {
        Wait::Exited(libc::WEXITSTATUS(status), peak)
    } else if libc::WIFSIGNALED(status) {
        Wait::Signaled(libc::WTERMSIG(status), peak)
    } else {
        Wait::Unknown
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cap_never_exceeds_the_machine_or_the_inherited_limit() {
        const G: u64 = 1 << 30;
        // Issue 32: the default budget (half of 16 GiB) gave 17 GiB, above the machine's 16.
        assert_eq!(clamp_cap(Some(8 * G), Some(16 * G), None), Some(16 * G));
        // And under a hard limit of 4 GiB every model's process failed to start.
        assert_eq!(
            clamp_cap(Some(8 * G), Some(16 * G), Some(4 * G)),
            Some(4 * G)
        );
        assert_eq!(clamp_cap(Some(G), Some(16 * G), None), Some(3 * G));
        assert_eq!(clamp_cap(None, None, None), None);
        assert_eq!(clamp_cap(Some(u64::MAX), None, None), Some(u64::MAX));
        let cap = address_space_cap(Some(u64::MAX / 4));
        if let (Some(cap), Some(m)) = (cap, machine_memory()) {
            assert!(cap <= m);
        }
    }
}
