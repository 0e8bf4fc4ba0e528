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
//              simulation of 1024 aircraft in one world; 1024 Predictor<double> x 9.2 KB = 9.4 MB,
//              beyond the private L2, so each step reloads its predictor from L3)
// Reported: steps_per_s, the aggregate over all threads (wall time, UseRealTime). The 1 -> 2
// thread scaling is steps_per_s(T=2) / steps_per_s(T=1), computed by run_all.sh.
//
// Warnings
// --------
// 1. Threads are created per iteration (about 50 us) against iterations of tens of ms: < 0.5 %.
// 2. On a shared 2-core VM the second thread competes with everything else on the machine.
#include <benchmark/benchmark.h>
#include <pthread.h>
#include <sched.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <thread>
#include <vector>

#include "bench_models.hpp"
#include "indicial/runtime.hpp"

namespace ib = indicial::bench;

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

void pin_self(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  sched_setaffinity(0, sizeof set, &set);
}

template <class Scalar>
void BM_Fleet(benchmark::State& state, Order order) {
  const int threads = static_cast<int>(state.range(0));
  auto fleet = std::make_unique<Fleet<Scalar>>();
  const int ncpu = static_cast<int>(std::thread::hardware_concurrency());
  int bad = 0;
  for (auto _ : state) {
    std::vector<std::thread> pool;
    std::vector<int> bad_of(threads, 0);
    for (int t = 1; t < threads; ++t) {
      pool.emplace_back([&, t] {
        pin_self(t % ncpu);
        bad_of[t] = fleet->advance(t * kAircraft / threads, (t + 1) * kAircraft / threads, order);
      });
    }
    pin_self(0);
    bad_of[0] = fleet->advance(0, kAircraft / threads, order);
    for (auto& th : pool) th.join();
    for (int b : bad_of) bad += b;
    benchmark::DoNotOptimize(fleet->sink.data());
    benchmark::ClobberMemory();
  }
  // Let the main thread run anywhere again.
  cpu_set_t all;
  CPU_ZERO(&all);
  for (int c = 0; c < ncpu; ++c) CPU_SET(c, &all);
  sched_setaffinity(0, sizeof all, &all);
  if (bad != 0) state.SkipWithError("Predictor::step returned a status other than ok");
  state.counters["steps_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * kAircraft * kStepsPerIteration,
      benchmark::Counter::kIsRate);
}

}  // namespace

void BM_batch_double(benchmark::State& s) { BM_Fleet<double>(s, Order::batch); }
void BM_batch_float(benchmark::State& s) { BM_Fleet<float>(s, Order::batch); }
void BM_lockstep_double(benchmark::State& s) { BM_Fleet<double>(s, Order::lockstep); }

BENCHMARK(BM_batch_double)->Name("batch/double")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_batch_float)->Name("batch/float")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_lockstep_double)->Name("lockstep/double")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
