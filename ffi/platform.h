/* Guards against C++ exceptions from the C++ libraries (Embree, OpenImageIO): a one-line exit
 * instead of an abort, and a dlopen that catches what a library's initialiser throws. */
#ifndef RAYLINK_PLATFORM_H
#define RAYLINK_PLATFORM_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

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
