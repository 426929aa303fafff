// parallel_allocation_guard.cpp -- a library the tests preload (LD_PRELOAD) into the lsnif program
// to find heap allocations made inside an active OpenMP parallel region. An exception cannot leave a
// parallel region: a std::bad_alloc thrown there (a machine short of memory) ends the process in
// std::terminate instead of reaching the command's "out of memory" message. Product code therefore
// sizes every buffer before its region. Under this guard every allocation requested while
// omp_get_active_level() > 0, by any thread of the team, fails (malloc returns null, so operator
// new throws), and the first few are named on stderr with "parallel_allocation_guard:"; a run that
// allocates inside a region aborts or reports out of memory, and says why. Allocations outside
// OpenMP regions (other threads: Embree's builders, lavapipe's) and libgomp's own (its teams and
// work shares, whose failure it reports itself) are untouched.
#include <dlfcn.h>
#include <omp.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <initializer_list>

extern "C" {
void* __libc_malloc(size_t size);
void* __libc_calloc(size_t count, size_t size);
void* __libc_realloc(void* pointer, size_t size);
void* __libc_memalign(size_t alignment, size_t size);
}

namespace {

std::atomic<int> g_reported{0};

// True when `caller` is in libgomp (its teams, work shares), the C library or the dynamic loader
// (a new thread's TLS): their allocations are not the program's, and they report failures themselves.
bool system_caller(const void* caller) {
  Dl_info info{};  // dladdr allocates nothing
  if (!dladdr(caller, &info) || !info.dli_fname) return false;
  const char* slash = std::strrchr(info.dli_fname, '/');
  const char* name = slash ? slash + 1 : info.dli_fname;
  for (const char* prefix : {"libgomp.so", "libc.so", "ld-linux"})
    if (std::strncmp(name, prefix, std::strlen(prefix)) == 0) return true;
  return false;
}

// True (and the request named, the first 16 times) when the program's code, at `caller`, asks
// inside an active region.
bool refused(const char* function, size_t size, const void* caller) {
  if (omp_get_active_level() == 0 || system_caller(caller)) return false;
  if (g_reported.fetch_add(1) < 16) {
    char line[160];
    const int n = std::snprintf(line, sizeof line,
                                "parallel_allocation_guard: %s(%zu) inside a parallel region (thread %d) refused\n",
                                function, size, omp_get_thread_num());
    if (n > 0) (void)!::write(2, line, size_t(n));  // no stdio buffer: nothing allocated here
  }
  return true;
}

}  // namespace

extern "C" {

void* malloc(size_t size) { return refused("malloc", size, __builtin_return_address(0)) ? nullptr : __libc_malloc(size); }

void* calloc(size_t count, size_t size) { return refused("calloc", count * size, __builtin_return_address(0)) ? nullptr : __libc_calloc(count, size); }

void* realloc(void* pointer, size_t size) { return refused("realloc", size, __builtin_return_address(0)) ? nullptr : __libc_realloc(pointer, size); }

void* memalign(size_t alignment, size_t size) {
  return refused("memalign", size, __builtin_return_address(0)) ? nullptr : __libc_memalign(alignment, size);
}

void* aligned_alloc(size_t alignment, size_t size) {
  return refused("aligned_alloc", size, __builtin_return_address(0)) ? nullptr : __libc_memalign(alignment, size);
}

int posix_memalign(void** out, size_t alignment, size_t size) {
  if (refused("posix_memalign", size, __builtin_return_address(0))) return ENOMEM;
  if (alignment % sizeof(void*) != 0 || (alignment & (alignment - 1)) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}

}  // extern "C"
