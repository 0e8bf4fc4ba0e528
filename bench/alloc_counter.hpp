// bench/alloc_counter.hpp -- counts every heap allocation made by the benchmark process.
//
// What it is for
// --------------
// The runtime promises zero heap allocations per step. Including this header in exactly ONE
// translation unit of a benchmark executable replaces the global operator new/delete (all
// forms) and malloc/calloc/realloc/free with versions that count calls and forward to glibc's
// own allocator (__libc_malloc etc.), so the count covers C++ and C allocations alike.
//
// Usage
// -----
//   #include "alloc_counter.hpp"   // in one .cpp only
//   const auto before = indicial::bench::allocation_count();
//   ... steps ...
//   const auto allocations = indicial::bench::allocation_count() - before;
//
// Warnings
// --------
// 1. glibc only (uses __libc_malloc and friends). Replacing malloc in the executable is the
//    interposition glibc documents ("Replacing malloc"); memalign / posix_memalign /
//    aligned_alloc are not replaced, so they are not counted (nothing in a step calls them).
// 2. The counter is process-wide and relaxed-atomic: read it around single-threaded sections.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
}

namespace indicial {
namespace bench {
inline std::atomic<unsigned long long>& allocation_counter() {
  static std::atomic<unsigned long long> count{0};
  return count;
}
inline unsigned long long allocation_count() {
  return allocation_counter().load(std::memory_order_relaxed);
}
}  // namespace bench
}  // namespace indicial

extern "C" {
void* malloc(std::size_t n) {
  indicial::bench::allocation_counter().fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
void* calloc(std::size_t count, std::size_t n) {
  indicial::bench::allocation_counter().fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(count, n);
}
void* realloc(void* p, std::size_t n) {
  indicial::bench::allocation_counter().fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
}

// operator new forwards to the counting malloc above; replaced explicitly so that a standard
// library built to call something else would still be counted.
void* operator new(std::size_t n) {
  void* p = std::malloc(n == 0 ? 1 : n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return std::malloc(n == 0 ? 1 : n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return std::malloc(n == 0 ? 1 : n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
