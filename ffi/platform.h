/* What the renderer needs of the processor and the operating system that Rust's standard
 * library does not give without unsafe code: the floating-point control word of the calling
 * thread, and the process's CPU time. */
#ifndef RAYLINK_PLATFORM_H
#define RAYLINK_PLATFORM_H

#ifdef __cplusplus
extern "C" {
#endif

/* Turns flush-to-zero and denormals-are-zero on for the calling thread (x86-64; nothing
 * elsewhere). Embree asks for both on every thread that traces rays. */
void raylink_flush_denormals(void);

/* 1 when both are on for the calling thread (always 1 off x86-64). */
int raylink_flush_denormals_enabled(void);

/* CPU seconds of the whole process (user + system, every thread, also threads that have
 * ended), to the nanosecond; a negative number when the clock cannot be read. */
double raylink_process_cpu_seconds(void);

#ifdef __cplusplus
}
#endif

#endif
