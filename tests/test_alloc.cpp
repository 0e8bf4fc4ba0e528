// Zero heap allocations in the runtime: load (from text), reset and 10000 steps, counted by
// replacing every global operator new / delete and, on glibc, malloc / calloc / realloc /
// free themselves (so a std::from_chars or libm call that used malloc would be seen too).
// Uses CHECK/REQUIRE, never assert(), so it counts in Release (NDEBUG) builds as well.
#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <new>

#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"
#include "test_support.hpp"

#if !defined(__GLIBC__)
#error "test_alloc counts malloc through glibc's __libc_malloc; port the wrapper for this libc"
#endif

namespace {
std::atomic<long> g_new_calls{0};
std::atomic<long> g_malloc_calls{0};
long allocations() { return g_new_calls.load() + g_malloc_calls.load(); }
}  // namespace

// --- malloc family, forwarded to glibc's own entry points ----------------------------------
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);

void* malloc(std::size_t n) noexcept {
  g_malloc_calls.fetch_add(1);
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t size) noexcept {
  g_malloc_calls.fetch_add(1);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t n) noexcept {
  g_malloc_calls.fetch_add(1);
  return __libc_realloc(p, n);
}
void free(void* p) noexcept { __libc_free(p); }
}

// --- every replaceable global operator new / delete ----------------------------------------
namespace {
void* counted_new(std::size_t n) {
  g_new_calls.fetch_add(1);
  void* p = __libc_malloc(n == 0 ? 1 : n);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
void* counted_new_aligned(std::size_t n, std::align_val_t al) {
  g_new_calls.fetch_add(1);
  const std::size_t a = static_cast<std::size_t>(al);
  void* p = std::aligned_alloc(a, ((n + a - 1) / a) * a);  // counted again: harmless
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return counted_new(n); }
void* operator new[](std::size_t n) { return counted_new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  g_new_calls.fetch_add(1);
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  g_new_calls.fetch_add(1);
  return __libc_malloc(n == 0 ? 1 : n);
}
void* operator new(std::size_t n, std::align_val_t a) { return counted_new_aligned(n, a); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted_new_aligned(n, a); }
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  g_new_calls.fetch_add(1);
  const std::size_t al = static_cast<std::size_t>(a);
  return std::aligned_alloc(al, ((n + al - 1) / al) * al);
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  g_new_calls.fetch_add(1);
  const std::size_t al = static_cast<std::size_t>(a);
  return std::aligned_alloc(al, ((n + al - 1) / al) * al);
}
void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete[](void* p) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t) noexcept { __libc_free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { __libc_free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { __libc_free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { __libc_free(p); }

namespace {
// Sinks the compiler cannot see through, so that deliberate allocations are not elided.
int* volatile g_int_sink = nullptr;
void* volatile g_void_sink = nullptr;

using indicial::testing::kPi;

// The file text lives in static storage before counting starts.
char g_text[16384];
std::size_t g_text_length = 0;

indicial::Predictor<double> g_predictor;  // static storage: large, not on the heap either
indicial::Predictor<float> g_predictor_f;
}  // namespace

TEST_CASE("the counter sees new and malloc") {
  const long before_new = g_new_calls.load();
  g_int_sink = new int(7);
  CHECK(g_new_calls.load() == before_new + 1);
  delete g_int_sink;
  g_int_sink = nullptr;
  const long before_malloc = g_malloc_calls.load();
  g_void_sink = std::malloc(24);
  CHECK(g_malloc_calls.load() == before_malloc + 1);
  std::free(g_void_sink);
  g_void_sink = nullptr;
  const long before_any = allocations();
  g_int_sink = new int[5];
  delete[] g_int_sink;
  CHECK(allocations() == before_any + 1);
}

TEST_CASE("load (text), reset and 10000 steps allocate nothing") {
  indicial::ModelSet<double, indicial::DefaultCapacity> m = indicial::test_models::lift_and_moment();
  // Cm's forcing delayed by 30 ms (31 samples at 1 ms): the delay history and its ring
  // wrap-around run too, and must not allocate either.
  m.coefficients[1].delay_s = 0.03;
  // CL carries both dynamic-stall families (a version-2 file): their steps allocate nothing.
  m.coefficients[0].stall = indicial::test_models::lift_and_moment_stall().coefficients[0].stall;
  const long before_write = allocations();
  const indicial::WriteStatus ws = indicial::write_coef_file(m, g_text, sizeof g_text, &g_text_length);
  const long write_allocations = allocations() - before_write;
  REQUIRE(ws == indicial::WriteStatus::ok);
  CHECK(write_allocations == 0);

  long load_allocations = 0;
  long reset_allocations = 0;
  long step_allocations = 0;
  int bad_steps = 0;
  double checksum = 0.0;
  for (int pass = 0; pass < 2; ++pass) {  // double, then float
    long a0 = allocations();
    const indicial::LoadStatus ls = pass == 0 ? g_predictor.load(g_text, g_text_length)
                                              : g_predictor_f.load(g_text, g_text_length);
    long a1 = allocations();
    const indicial::StepStatus rs = pass == 0 ? g_predictor.reset(0.6, 17.667762)
                                              : g_predictor_f.reset(0.6, 17.667762);
    long a2 = allocations();
    indicial::Predictor<double>::Outputs out;
    indicial::Predictor<float>::Outputs out_f;
    for (int k = 1; k <= 10000; ++k) {
      const double t = 0.001 * k;
      const double w = 2.0 * kPi;
      const indicial::MotionInput in{0.6 + 0.6 * std::sin(w * t), 0.6 * w * std::cos(w * t),
                                     17.667762};
      const indicial::StepStatus s = pass == 0 ? g_predictor.step(in, 0.001, &out)
                                               : g_predictor_f.step(in, 0.001, &out_f);
      bad_steps += (s != indicial::StepStatus::ok);
      checksum += pass == 0 ? out.value[0] + out.value[1] : double(out_f.value[0] + out_f.value[1]);
    }
    long a3 = allocations();
    REQUIRE(ls == indicial::LoadStatus::ok);
    REQUIRE(rs == indicial::StepStatus::ok);
    load_allocations += a1 - a0;
    reset_allocations += a2 - a1;
    step_allocations += a3 - a2;
    // Refusals allocate nothing either.
    a0 = allocations();
    indicial::ParseDiagnostic diag;
    const indicial::LoadStatus refused = g_predictor.load(g_text, g_text_length / 2, &diag);
    a1 = allocations();
    REQUIRE(refused == indicial::LoadStatus::truncated);
    load_allocations += a1 - a0;
  }
  CHECK(load_allocations == 0);
  CHECK(reset_allocations == 0);
  CHECK(step_allocations == 0);
  CHECK(bad_steps == 0);
  CHECK(std::isfinite(checksum));
}
