/* What the renderer needs of the processor and the operating system that Rust's standard
 * library does not give without unsafe code: the floating-point control word of the calling
 * thread, the process's CPU time, and a one-line exit instead of an abort when memory runs
 * out. */
#ifndef RAYLINK_PLATFORM_H
#define RAYLINK_PLATFORM_H

#include <stddef.h>

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

/* Writes "raylink: error: cannot allocate BYTES bytes: out of memory ..." to stderr and ends
 * the process with status 1 at once (no allocation, no unwinding): for memory the system
 * refuses where the program cannot go on. */
void raylink_exit_out_of_memory(unsigned long long bytes);

/* From now on, a C++ exception that nothing catches (in Embree or its task scheduler, which
 * end the process with abort otherwise) calls `before_exit`, writes one line naming it to
 * stderr and ends the process with status 1. Defined in `ffi/exceptions.cpp`. */
void raylink_exit_on_terminate(void (*before_exit)(void));

/* dlopen(path, RTLD_NOW | RTLD_LOCAL), with an exception thrown by a library's initialiser
 * caught: NULL and the reason in `err` (always terminated) on failure. Defined in
 * `ffi/exceptions.cpp`. */
void* raylink_dlopen(const char* path, char* err, size_t err_len);

#ifdef __cplusplus
}
#endif

#endif
