//! The processor and operating-system settings the renderer needs: flush-to-zero for the
//! threads that trace rays, and the process's CPU time for figures that must hold on a
//! shared machine. A thin wrapper over `ffi/platform.c`.

/// Turns flush-to-zero and denormals-are-zero on for the calling thread. Embree asks for
/// both on every thread that traces rays (denormal arithmetic is many times slower); the
/// tile driver sets them on its workers.
pub fn set_flush_denormals() {
    // SAFETY: the C function only sets two bits of this thread's floating-point control
    // register; it takes no arguments and touches no memory.
    unsafe { sys::raylink_flush_denormals() }
}

/// Whether flush-to-zero and denormals-are-zero are on for the calling thread.
pub fn flush_denormals_enabled() -> bool {
    // SAFETY: reads this thread's floating-point control register only.
    unsafe { sys::raylink_flush_denormals_enabled() != 0 }
}

/// CPU time of the process so far (user + system, every thread, also threads that have
/// ended), to the nanosecond; 0 where the clock cannot be read.
pub fn cpu_seconds() -> f64 {
    // SAFETY: clock_gettime writes only into a local struct of the C function.
    unsafe { sys::raylink_process_cpu_seconds() }.max(0.0)
}

/// Declarations matching `ffi/platform.h`.
mod sys {
    extern "C" {
        pub fn raylink_flush_denormals();
        pub fn raylink_flush_denormals_enabled() -> std::os::raw::c_int;
        pub fn raylink_process_cpu_seconds() -> f64;
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
