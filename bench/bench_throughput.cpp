// bench/bench_throughput.cpp -- many independent predictors on 1 and 2 threads.
//
// What it measures
// ----------------
// A Monte Carlo batch or a many-aircraft simulation steps many independent Predictors. Here
// 1024 Predictor<Scalar> (Model II, C_L + C_m, bench_models.hpp), each on its own phase of the
// 35 +/- 35 deg, 1 Hz motion at 1 kHz, are split evenly over T threads (T = 1, 2; each thread
// pinned to its own CPU). One benchmark iteration advances every predictor by 1000 steps
// (1 s of flight), in one of two orders:
//   batch/     predictor-major: each predictor runs its 1000 steps before the next (a Monte
//              Carlo batch: one model and state stay in L1 for 1000 steps)
//   lockstep/  time-major: every predictor advances one step before any advances again (a
//              simulation of 1024 aircraft in one world; each Predictor carries its own copy of
//              the model, 1024 x 13.7 KB = 14 MB, beyond the private L2)
// and, for 1024 instances sharing ONE model (a 160-byte State each: 160 KB in all), lockstep:
//   shared/    indicial::step per instance; stepbatch/ indicial::step_batch (the automatic
//              kernel: AVX2 on a CPU that has it); stepbatch_portable/ the same with the
//              portable kernel (SSE2 in the default build); cbatch/ the C interface's
//              indicial_step_batch (see SharedFleet). The context line batch_kernel says which
//              kernel the automatic choice ran.
// Reported: steps_per_s, the aggregate over all threads (wall time, UseRealTime), and
// cpu_ns_per_step, the stepping threads' own CPU time (CLOCK_THREAD_CPUTIME_ID) per
// instance-step, which a loaded machine inflates much less than the wall time. The 1 -> 2
// thread scaling is steps_per_s(T=2) / steps_per_s(T=1), computed by make_results.py.
// Thread t steps its own contiguous range, a multiple of 8 instances, on cache-line aligned
// arrays (CacheLineAllocator): no cache line is written by both threads.
//
// Warnings
// --------
// 1. Threads are created per iteration (about 50 us) against iterations of tens of ms: < 0.5 %.
// 2. On a shared 2-core VM the second thread competes with everything else on the machine.
#include <benchmark/benchmark.h>
#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <new>
#include <thread>
#include <vector>

#include "bench_models.hpp"
#include "indicial/batch.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/indicial.h"
#include "indicial/runtime.hpp"

namespace ib = indicial::bench;
using Cap = indicial::DefaultCapacity;

namespace {

constexpr int kAircraft = 1024;
constexpr int kStepsPerIteration = 1000;
constexpr double kDtS = 1e-3;

enum class Order : int { batch = 0, lockstep = 1 };

template <class Scalar>
struct Fleet {
  std::vector<indicial::Predictor<Scalar>> predictors;
  std::vector<std::size_t> phase;  // each aircraft's index into the motion table
  ib::Motion<double> motion{1.0 / kDtS};
  std::vector<double> sink;        // one output per aircraft: keeps the work observable

  Fleet() : predictors(kAircraft), phase(kAircraft), sink(kAircraft, 0.0) {
    const auto set = ib::make_model_set<double>(ib::ModelKind::model_ii);
    for (int a = 0; a < kAircraft; ++a) {
      if (predictors[a].load(set) != indicial::LoadStatus::ok) std::abort();
      phase[a] = static_cast<std::size_t>(a * 7) % motion.size();
      predictors[a].reset(motion.angle_rad(phase[a]), ib::kAirspeedMps);
    }
  }

  // Advances aircraft [begin, end) by kStepsPerIteration steps; returns the non-ok count.
  int advance(int begin, int end, Order order) {
    typename indicial::Predictor<Scalar>::Outputs out;
    int bad = 0;
    const std::size_t n = motion.size();
    if (order == Order::batch) {
      for (int a = begin; a < end; ++a) {
        std::size_t m = phase[a];
        double acc = 0.0;
        for (int s = 0; s < kStepsPerIteration; ++s) {
          if (++m == n) m = 0;
          const indicial::MotionInput in{motion.angle_rad(m), motion.rate_radps(m),
                                         ib::kAirspeedMps};
          bad += predictors[a].step(in, kDtS, &out) != indicial::StepStatus::ok;
          acc += static_cast<double>(out.value[0] + out.value[1]);
        }
        phase[a] = m;
        sink[a] = acc;
      }
    } else {
      for (int s = 0; s < kStepsPerIteration; ++s) {
        for (int a = begin; a < end; ++a) {
          std::size_t m = phase[a] + 1;
          if (m == n) m = 0;
          phase[a] = m;
          const indicial::MotionInput in{motion.angle_rad(m), motion.rate_radps(m),
                                         ib::kAirspeedMps};
          bad += predictors[a].step(in, kDtS, &out) != indicial::StepStatus::ok;
          sink[a] += static_cast<double>(out.value[0] + out.value[1]);
        }
      }
    }
    return bad;
  }
};

// Storage on 64-byte cache lines: with every array of SharedFleet aligned and each thread's
// range a multiple of batch_block (8) instances, no cache line holds data of two threads
// (8 States = 1280 bytes = 20 lines, 8 angles = 1 line, 8 out rows = 2 lines): no false
// sharing between the threads.
template <class T>
struct CacheLineAllocator {
  using value_type = T;
  static constexpr std::size_t line_bytes = 64;
  CacheLineAllocator() = default;
  template <class U>
  CacheLineAllocator(const CacheLineAllocator<U>&) {}
  T* allocate(std::size_t n) {
    return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(line_bytes)));
  }
  void deallocate(T* p, std::size_t) { ::operator delete(p, std::align_val_t(line_bytes)); }
  template <class U>
  bool operator==(const CacheLineAllocator<U>&) const { return true; }
  template <class U>
  bool operator!=(const CacheLineAllocator<U>&) const { return false; }
};
template <class T>
using LineVector = std::vector<T, CacheLineAllocator<T>>;

// Thread t's range of aircraft [first, first of t + 1): even shares, each a multiple of
// batch_block instances (so of whole cache lines, see CacheLineAllocator).
int range_begin(int t, int threads) {
  const int blocks = kAircraft / indicial::batch_block;
  return t * blocks / threads * indicial::batch_block;
}

// 1024 instances sharing ONE model: a State (160 bytes for double) each, the RuntimeModel once
// (it stays in cache). Time-major (lockstep) like a simulation of many aircraft, stepped by
//   shared/    indicial::step per instance
//   stepbatch/ indicial::step_batch over each thread's range, automatic kernel
//   stepbatch_portable/ the same, BatchKernel::portable
//   cbatch/    indicial_step_batch, the C interface
enum class SharedMode : int { single = 0, batch = 1, c_batch = 2, batch_portable = 3 };

struct SharedFleet {
  std::unique_ptr<indicial::RuntimeModel<double, Cap>> model;
  LineVector<indicial::State<double, Cap>> states;
  std::vector<double> c_model;   // the C interface's storage (double-aligned)
  LineVector<double> c_states;
  std::size_t c_state_bytes = 0;
  LineVector<std::size_t> phase;
  LineVector<double> angle, rate, airspeed, out, sink;
  ib::Motion<double> motion{1.0 / kDtS};

  SharedFleet()
      : model(std::make_unique<indicial::RuntimeModel<double, Cap>>()), states(kAircraft),
        c_model(indicial_model_bytes() / sizeof(double) + 1), phase(kAircraft), angle(kAircraft),
        rate(kAircraft), airspeed(kAircraft, ib::kAirspeedMps), out(2 * kAircraft),
        sink(kAircraft, 0.0) {
    const auto set = ib::make_model_set<double>(ib::ModelKind::model_ii);
    if (indicial::make_runtime_model(set, model.get()) != indicial::LoadStatus::ok) std::abort();
    char text[8192];
    std::size_t n = 0;
    if (indicial::write_coef_file(set, text, sizeof text, &n) != indicial::WriteStatus::ok ||
        indicial_model_load(c_model.data(), text, n, nullptr, 0) != INDICIAL_OK)
      std::abort();
    c_state_bytes = indicial_state_bytes(c_model.data());
    c_states.resize(kAircraft * c_state_bytes / sizeof(double) + 1);
    for (int a = 0; a < kAircraft; ++a) {
      phase[a] = static_cast<std::size_t>(a * 7) % motion.size();
      indicial::reset(*model, states[a], motion.angle_rad(phase[a]), ib::kAirspeedMps);
      indicial_reset(c_model.data(), c_state(a), motion.angle_rad(phase[a]), ib::kAirspeedMps);
    }
  }
  void* c_state(int a) { return reinterpret_cast<char*>(c_states.data()) + a * c_state_bytes; }

  int advance(int begin, int end, SharedMode mode) {
    int bad = 0;
    const std::size_t n = motion.size();
    const std::size_t count = static_cast<std::size_t>(end - begin);
    for (int s = 0; s < kStepsPerIteration; ++s) {
      for (int a = begin; a < end; ++a) {
        std::size_t m = phase[a] + 1;
        if (m == n) m = 0;
        phase[a] = m;
        angle[a] = motion.angle_rad(m);
        rate[a] = motion.rate_radps(m);
      }
      if (mode == SharedMode::single) {
        for (int a = begin; a < end; ++a)
          bad += indicial::step(*model, states[a], {angle[a], rate[a], airspeed[a]}, kDtS,
                                &out[2 * a]) != indicial::StepStatus::ok;
      } else if (mode == SharedMode::batch || mode == SharedMode::batch_portable) {
        const indicial::BatchKernel kernel = mode == SharedMode::batch
                                                 ? indicial::BatchKernel::automatic
                                                 : indicial::BatchKernel::portable;
        bad += indicial::step_batch(*model, &states[begin], count, &angle[begin], &rate[begin],
                                    &airspeed[begin], kDtS, &out[2 * begin], nullptr,
                                    kernel) != indicial::StepStatus::ok;
      } else {
        bad += indicial_step_batch(c_model.data(), c_state(begin), count, &angle[begin],
                                   &rate[begin], &airspeed[begin], kDtS, &out[2 * begin]) != INDICIAL_OK;
      }
      for (int a = begin; a < end; ++a) sink[a] += out[2 * a] + out[2 * a + 1];
    }
    return bad;
  }
};

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

void pin_self(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  sched_setaffinity(0, sizeof set, &set);
}

template <class FleetT, class ModeT>
void run_fleet(benchmark::State& state, ModeT order) {
  const int threads = static_cast<int>(state.range(0));
  auto fleet = std::make_unique<FleetT>();
  const int ncpu = static_cast<int>(std::thread::hardware_concurrency());
  int bad = 0;
  double cpu_s = 0.0;  // CPU time of the stepping threads, all together
  for (auto _ : state) {
    std::vector<std::thread> pool;
    std::vector<int> bad_of(threads, 0);
    std::vector<double> cpu_s_of(threads, 0.0);
    for (int t = 1; t < threads; ++t) {
      pool.emplace_back([&, t] {
        pin_self(t % ncpu);
        const double c0 = thread_cpu_s();
        bad_of[t] = fleet->advance(range_begin(t, threads), range_begin(t + 1, threads), order);
        cpu_s_of[t] = thread_cpu_s() - c0;
      });
    }
    pin_self(0);
    const double c0 = thread_cpu_s();
    bad_of[0] = fleet->advance(0, range_begin(1, threads), order);
    cpu_s_of[0] = thread_cpu_s() - c0;
    for (auto& th : pool) th.join();
    for (int b : bad_of) bad += b;
    for (double c : cpu_s_of) cpu_s += c;
    benchmark::DoNotOptimize(fleet->sink.data());
    benchmark::ClobberMemory();
  }
  // Let the main thread run anywhere again.
  cpu_set_t all;
  CPU_ZERO(&all);
  for (int c = 0; c < ncpu; ++c) CPU_SET(c, &all);
  sched_setaffinity(0, sizeof all, &all);
  if (bad != 0) state.SkipWithError("Predictor::step returned a status other than ok");
  const double steps = static_cast<double>(state.iterations()) * kAircraft * kStepsPerIteration;
  // The stepping threads' own CPU time per instance-step: what a step costs, without the time
  // spent waiting for a CPU on a loaded machine (1e9 / this = instance-steps per CPU-second).
  state.counters["cpu_ns_per_step"] = cpu_s * 1e9 / steps;
  state.counters["steps_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * kAircraft * kStepsPerIteration,
      benchmark::Counter::kIsRate);
}

}  // namespace

void BM_batch_double(benchmark::State& s) { run_fleet<Fleet<double>>(s, Order::batch); }
void BM_batch_float(benchmark::State& s) { run_fleet<Fleet<float>>(s, Order::batch); }
void BM_lockstep_double(benchmark::State& s) { run_fleet<Fleet<double>>(s, Order::lockstep); }
void BM_shared_double(benchmark::State& s) { run_fleet<SharedFleet>(s, SharedMode::single); }
void BM_stepbatch_double(benchmark::State& s) { run_fleet<SharedFleet>(s, SharedMode::batch); }
void BM_cbatch_double(benchmark::State& s) { run_fleet<SharedFleet>(s, SharedMode::c_batch); }
void BM_stepbatch_portable_double(benchmark::State& s) {
  run_fleet<SharedFleet>(s, SharedMode::batch_portable);
}

BENCHMARK(BM_batch_double)->Name("batch/double")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_batch_float)->Name("batch/float")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_lockstep_double)->Name("lockstep/double")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_shared_double)->Name("shared/double")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_stepbatch_double)->Name("stepbatch/double")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_cbatch_double)->Name("cbatch/double")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_stepbatch_portable_double)->Name("stepbatch_portable/double")->Arg(1)->Arg(2)
    ->UseRealTime()->Unit(benchmark::kMillisecond);

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  // Which kernel step_batch's automatic choice (stepbatch/, and cbatch/ in the C library) runs.
  benchmark::AddCustomContext("batch_kernel", indicial::to_string(indicial::batch_kernel_in_use()));
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
