// parallel_allocation_probe.cpp -- the control of parallel_allocation_guard: allocates once on each
// of two threads of a parallel region and once outside it, and prints "threads T refused R
// outside ok|refused". Under the guard R = T and the allocation outside succeeds; without it R = 0.
#include <omp.h>

#include <atomic>
#include <cstdio>
#include <new>

namespace {
char* volatile g_sink = nullptr;  // the allocations escape, so the compiler keeps them

bool allocates() {
  try {
    char* p = new char[4096];
    g_sink = p;
    delete[] g_sink;
    return true;
  } catch (const std::bad_alloc&) {
    return false;
  }
}
}  // namespace

int main() {
  std::atomic<int> refused{0}, threads{0};
#pragma omp parallel num_threads(2)
  {
    if (!allocates()) ++refused;
    ++threads;
  }
  const bool outside = allocates();
  std::printf("threads %d refused %d outside %s\n", threads.load(), refused.load(), outside ? "ok" : "refused");
  return 0;
}
