//! The binary's allocator: the system's, except that a failed allocation ends the process with
//! one line on stderr and exit code 2 instead of Rust's abort (exit 134). The builder refuses
//! builds its memory budget predicts will not fit; this catches what the prediction misses.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;

/// [`System`], with out-of-memory turned into a clean exit.
pub struct ExitOnOom;

impl ExitOnOom {
    #[cold]
    fn out_of_memory(layout: Layout) -> ! {
        // No allocation from here on: format into a fixed buffer, write it raw.
        let mut buf = [0u8; 192];
        let mut w = std::io::Cursor::new(&mut buf[..]);
        let _ = writeln!(
            w,
            "sdfmo: error: out of memory: an allocation of {} bytes failed (try a smaller depth or --max-memory)",
            layout.size()
        );
        let len = w.position() as usize;
        let _ = std::io::stderr().write_all(&buf[..len]);
        std::process::exit(2)
    }
}

// SAFETY: every method forwards to `System` with the same arguments; only a null result is
// intercepted, and then the process exits instead of returning.
unsafe impl GlobalAlloc for ExitOnOom {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller upholds `GlobalAlloc::alloc`'s contract, which `System` shares.
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            Self::out_of_memory(layout);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            Self::out_of_memory(layout);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by `System` with `layout` (every allocation goes there).
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as for `dealloc`; `new_size` is the caller's, checked by `System`.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            // SAFETY: `Layout::from_size_align_unchecked` requirements hold: `layout`'s align
            // is valid and the caller guarantees `new_size` does not overflow when rounded.
            Self::out_of_memory(unsafe {
                Layout::from_size_align_unchecked(new_size, layout.align())
            });
        }
        p
    }
}
