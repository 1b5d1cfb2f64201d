//! The processor and operating-system settings the renderer needs: flush-to-zero for the
//! threads that trace rays, and the process's CPU time for figures that must hold on a
//! shared machine, and a one-line exit instead of an abort when the system refuses memory.
//! Pure Rust, but for the guards against C++ exceptions in `ffi/exceptions.cpp`, built with
//! the C++ libraries (Embree, OpenImageIO) that throw them.

use crate::error::{Error, Result};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// Turns flush-to-zero and denormals-are-zero on for the calling thread. Embree asks for
/// both on every thread that traces rays (denormal arithmetic is many times slower); the
/// tile driver sets them on its workers.
pub fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: sets two bits of this thread's floating-point control register (MXCSR, present
    // on every x86-64), which only changes how denormal floats are computed.
    #[allow(deprecated)]
    unsafe {
        use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
        _mm_setcsr(_mm_getcsr() | FTZ_DAZ)
    }
}

/// Whether flush-to-zero and denormals-are-zero are on for the calling thread (always true
/// off x86-64, where nothing is set).
pub fn flush_denormals_enabled() -> bool {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: reads this thread's floating-point control register only.
    #[allow(deprecated)]
    let enabled = unsafe { std::arch::x86_64::_mm_getcsr() } & FTZ_DAZ == FTZ_DAZ;
    #[cfg(not(target_arch = "x86_64"))]
    let enabled = true;
    enabled
}

/// MXCSR bits: flush-to-zero (bit 15) and denormals-are-zero (bit 6).
#[cfg(target_arch = "x86_64")]
const FTZ_DAZ: u32 = 0x8040;

/// The hardware threads this process may run on (1 where the system cannot say): what
/// "every core" means for thread counts.
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The most worker threads a job, the bench or the command line's thread pool may start: 16
/// per core, at least 64. Threads past a few per core only cost memory and start-up, and a
/// huge count would exhaust the system before any work.
pub fn max_threads() -> usize {
    (16 * cores()).max(64)
}

/// [`Error::Setting`] for a thread count outside 1 to [`max_threads`]; `name` is the setting.
pub fn check_threads(name: &str, threads: usize) -> Result<()> {
    let limit = max_threads();
    if threads == 0 || threads > limit {
        return Err(Error::setting(
            name,
            format!("must be between 1 and {limit} (16 per core), got {threads}"),
        ));
    }
    Ok(())
}

/// CPU time of the process so far (user + system, every thread, also threads that have
/// ended), to the nanosecond; 0 where the clock cannot be read.
pub fn cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut t = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: clock_gettime writes only into `t`, a live local.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) } != 0 {
            return 0.0;
        }
        t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
    }
    #[cfg(not(unix))]
    0.0
}

/// The system allocator for a program (the command line) that would rather end with one line
/// and exit status 1 than abort when the system refuses memory (a process limit such as
/// `ulimit -v`, other programs using the memory). Install it with
/// `#[global_allocator] static A: ExitOnOutOfMemory = ExitOnOutOfMemory;`.
///
/// Allocations that can fail without ending the program ([`fallible`], which the library's
/// `try_reserve` uses for its large buffers) still get their error; any other refused
/// allocation removes the temporary files being written, writes
/// `raylink: error: cannot allocate N bytes: out of memory (...)` and exits at once.
pub struct ExitOnOutOfMemory;

// SAFETY: every method forwards to the system allocator with the same arguments and returns
// its result; the only addition, on a null result, ends the process without returning.
unsafe impl GlobalAlloc for ExitOnOutOfMemory {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `layout` is the system allocator's.
        checked(unsafe { System.alloc(layout) }, layout.size())
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as `alloc`.
        checked(unsafe { System.alloc_zeroed(layout) }, layout.size())
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `ptr` and `layout` come from this allocator, which is the system's.
        checked(unsafe { System.realloc(ptr, layout, new_size) }, new_size)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` and `layout` come from this allocator, which is the system's.
        unsafe { System.dealloc(ptr, layout) }
    }
}

thread_local! {
    /// Set while this thread runs [`fallible`]: a refused allocation is returned as such.
    static FALLIBLE: Cell<bool> = const { Cell::new(false) };
    /// Set while this thread is ending the process, so that an allocation on the way (a long
    /// path's name) does not start it again.
    static ENDING: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f` (a `try_reserve`) with refused allocations returned to it as errors, under
/// [`ExitOnOutOfMemory`] as under the system allocator.
pub fn fallible<T>(f: impl FnOnce() -> T) -> T {
    let before = FALLIBLE.with(|c| c.replace(true));
    let result = f();
    FALLIBLE.with(|c| c.set(before));
    result
}

/// A vector of `len` copies of `value`, or [`Error::OutOfMemory`] naming `what` if it cannot
/// be allocated (instead of aborting the process, as `vec!` would).
pub(crate) fn try_vec<T: Clone>(
    len: usize,
    value: T,
    what: impl FnOnce() -> String,
) -> Result<Vec<T>> {
    let mut v = Vec::new();
    try_reserve(&mut v, len, what)?;
    v.resize(len, value);
    Ok(v)
}

/// Reserves room for exactly `additional` more elements in `v`, or [`Error::OutOfMemory`]
/// naming `what`.
pub(crate) fn try_reserve<T>(
    v: &mut Vec<T>,
    additional: usize,
    what: impl FnOnce() -> String,
) -> Result<()> {
    fallible(|| v.try_reserve_exact(additional)).map_err(|_| Error::OutOfMemory {
        what: what(),
        bytes: (additional as u64).saturating_mul(std::mem::size_of::<T>() as u64),
    })
}

fn checked(ptr: *mut u8, bytes: usize) -> *mut u8 {
    if ptr.is_null() && !FALLIBLE.with(Cell::get) {
        remove_temporaries_before_exit();
        exit_out_of_memory(bytes);
    }
    ptr
}

/// Reads exactly `buf.len()` bytes of `file` from `offset`, without moving a shared file
/// position: several threads read one file at once.
pub(crate) fn read_exact_at(
    file: &std::fs::File,
    buf: &mut [u8],
    offset: u64,
) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::os::unix::fs::FileExt::read_exact_at(file, buf, offset)
    }
    #[cfg(windows)]
    {
        let (mut buf, mut offset) = (buf, offset);
        while !buf.is_empty() {
            match std::os::windows::fs::FileExt::seek_read(file, buf, offset) {
                Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
                Ok(n) => {
                    buf = &mut buf[n..];
                    offset += n as u64;
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }
}

/// Writes one line to stderr and ends the process with status 1 at once: no allocation (the
/// line is formatted on the stack), no unwinding, no exit handlers (the C++ libraries' static
/// destructors would run without memory).
fn exit_out_of_memory(bytes: usize) -> ! {
    use std::io::Write;
    let mut line = [0u8; 256];
    let len = {
        let mut cursor = std::io::Cursor::new(&mut line[..]);
        let _ = writeln!(
            cursor,
            "raylink: error: cannot allocate {bytes} bytes: out of memory (a process limit \
             such as ulimit -v, or other programs using the memory)"
        );
        cursor.position() as usize
    };
    // Standard error is unbuffered: this is one write of the stack buffer.
    let _ = std::io::stderr().write_all(&line[..len]);
    // SAFETY: ends the process; nothing runs after it.
    unsafe { libc::_exit(1) }
}

/// From now on an uncaught C++ exception (Embree's task scheduler throws one when the system
/// refuses it memory in the middle of a build) removes the temporary files being written,
/// writes one line naming it and ends the process with status 1, instead of aborting. For
/// programs, as [`ExitOnOutOfMemory`].
/// A build without the C++ libraries has no C++ exception to guard against: nothing to do.
pub fn exit_on_uncaught_exceptions() {
    #[cfg(any(feature = "embree", feature = "oiio"))]
    // SAFETY: stores a function pointer and sets the C++ terminate handler; the handler
    // calls `remove_temporaries_before_exit`, which neither unwinds nor returns an error.
    unsafe {
        sys::raylink_exit_on_terminate(remove_temporaries_before_exit)
    }
}

/// Removes the temporary files being written, once per thread however the exit comes.
extern "C" fn remove_temporaries_before_exit() {
    if !ENDING.with(|c| c.replace(true)) {
        crate::atomic_file::remove_temporaries_if_free();
    }
}

#[cfg(feature = "oiio")]
/// Loads the shared object at `path` (as `dlopen` with `RTLD_NOW | RTLD_LOCAL`), with a C++
/// exception from its libraries' initialisers (memory the system refuses while they start)
/// returned as an error: one unwinding into Rust would abort the process.
///
/// # Safety
/// Loading runs the object's initialisers and those of the libraries it needs: the caller
/// vouches that they only set up their own state.
pub(crate) unsafe fn load_library(path: &std::path::Path) -> Result<libloading::Library, String> {
    use std::os::unix::ffi::OsStrExt;
    let c_path = std::ffi::CString::new(path.as_os_str().as_bytes())
        .map_err(|_| format!("{}: a path with a NUL byte", path.display()))?;
    let mut err = [0 as std::os::raw::c_char; 512];
    // SAFETY: both buffers are valid for the call and `err` for its length; the caller
    // vouches for the initialisers.
    let handle = unsafe { sys::raylink_dlopen(c_path.as_ptr(), err.as_mut_ptr(), err.len()) };
    if handle.is_null() {
        // SAFETY: the C function always terminates `err`.
        let reason = unsafe { std::ffi::CStr::from_ptr(err.as_ptr()) };
        return Err(reason.to_string_lossy().into_owned());
    }
    // SAFETY: `handle` is a live handle from dlopen, owned from here on by the Library,
    // which closes it when dropped.
    Ok(unsafe { libloading::os::unix::Library::from_raw(handle) }.into())
}

/// Declarations matching `ffi/platform.h`.
#[cfg(any(feature = "embree", feature = "oiio"))]
mod sys {
    extern "C" {
        pub(crate) fn raylink_exit_on_terminate(before_exit: extern "C" fn());
        #[cfg(feature = "oiio")]
        pub(crate) fn raylink_dlopen(
            path: *const std::os::raw::c_char,
            err: *mut std::os::raw::c_char,
            err_len: usize,
        ) -> *mut std::os::raw::c_void;
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn flush_to_zero_is_set_per_thread() {
        std::thread::spawn(|| {
            super::set_flush_denormals();
            assert!(super::flush_denormals_enabled());
            // A denormal product flushes to zero.
            let tiny = std::hint::black_box(1e-30f32);
            assert_eq!(tiny * std::hint::black_box(1e-10f32), 0.0);
        })
        .join()
        .unwrap();
    }

    #[test]
    fn cpu_time_advances_with_work() {
        let a = super::cpu_seconds();
        let mut x = 0u64;
        for i in 0..50_000_000u64 {
            x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(i));
        }
        assert!(super::cpu_seconds() > a, "{x}");
    }
}
