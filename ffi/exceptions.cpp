// C++ exceptions that would end the process with an abort. One that nothing catches ends it
// through std::terminate (SIGABRT, a core dump, a multi-line message): Embree's task
// scheduler does this when the system refuses memory in the middle of a build, and raylink's
// command line installs a handler that writes one line and exits with status 1 instead. One
// thrown by a library's initialiser while it is loaded would unwind into Rust, which aborts
// on foreign exceptions: libraries are loaded here, inside a catch.

#include "platform.h"

#include <cstdio>
#include <dlfcn.h>
#include <exception>
#include <new>
#include <unistd.h>

namespace {

void (*run_before_exit)(void) = nullptr;

// Writes the line snprintf made of `n` characters into a buffer of `size` (cut to fit).
void write_line(const char* line, int n, size_t size) {
    if (n > 0) {
        size_t len = static_cast<size_t>(n) < size ? static_cast<size_t>(n) : size - 1;
        ssize_t written = write(2, line, len);
        (void)written;
    }
}

[[noreturn]] void on_terminate() {
    if (run_before_exit != nullptr) {
        run_before_exit();
    }
    char line[512];
    int n = 0;
    std::exception_ptr current = std::current_exception();
    try {
        if (current) {
            std::rethrow_exception(current);
        }
        n = std::snprintf(line, sizeof line,
                          "raylink: error: a system library ended the work without an "
                          "exception\n");
    } catch (const std::bad_alloc&) {
        n = std::snprintf(line, sizeof line,
                          "raylink: error: out of memory in Embree (a process limit such as "
                          "ulimit -v, or other programs using the memory)\n");
    } catch (const std::exception& e) {
        n = std::snprintf(line, sizeof line,
                          "raylink: error: Embree stopped with an uncaught exception (%.300s; "
                          "seen when the system refuses memory to its task scheduler)\n",
                          e.what());
    } catch (...) {
        n = std::snprintf(line, sizeof line,
                          "raylink: error: Embree stopped with an uncaught exception\n");
    }
    write_line(line, n, sizeof line);
    _exit(1);
}

}  // namespace

extern "C" void raylink_exit_on_terminate(void (*before_exit)(void)) {
    run_before_exit = before_exit;
    std::set_terminate(on_terminate);
}

extern "C" void* raylink_dlopen(const char* path, char* err, size_t err_len) {
    const char* reason = nullptr;
    try {
        void* handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
        if (handle != nullptr) {
            return handle;
        }
        reason = dlerror();
    } catch (const std::bad_alloc&) {
        reason = "out of memory while its libraries started";
    } catch (const std::exception& e) {
        std::snprintf(err, err_len, "its libraries failed to start: %s", e.what());
        return nullptr;
    } catch (...) {
        reason = "its libraries failed to start";
    }
    std::snprintf(err, err_len, "%s", reason != nullptr ? reason : "unknown error");
    return nullptr;
}
