#include "platform.h"

#include <stdio.h>
#include <time.h>
#include <unistd.h>
#if defined(__x86_64__)
#include <xmmintrin.h>
#endif

/* MXCSR bits: flush-to-zero (bit 15) and denormals-are-zero (bit 6). */
#define RAYLINK_FTZ_DAZ 0x8040u

void raylink_flush_denormals(void) {
#if defined(__x86_64__)
    _mm_setcsr(_mm_getcsr() | RAYLINK_FTZ_DAZ);
#endif
}

int raylink_flush_denormals_enabled(void) {
#if defined(__x86_64__)
    return (_mm_getcsr() & RAYLINK_FTZ_DAZ) == RAYLINK_FTZ_DAZ;
#else
    return 1;
#endif
}

double raylink_process_cpu_seconds(void) {
    struct timespec t;
    if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t) != 0) {
        return -1.0;
    }
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

void raylink_exit_out_of_memory(unsigned long long bytes) {
    char line[256];
    /* snprintf with integer conversions only: it does not allocate. */
    int n = snprintf(line, sizeof line,
                     "raylink: error: cannot allocate %llu bytes: out of memory (a process limit "
                     "such as ulimit -v, or other programs using the memory)\n",
                     bytes);
    if (n > 0) {
        size_t len = (size_t)n < sizeof line ? (size_t)n : sizeof line - 1;
        ssize_t written = write(2, line, len);
        (void)written;
    }
    _exit(1);
}
