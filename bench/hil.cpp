// bench/hil.cpp -- hardware-in-the-loop timing: the runtime inside a periodic real-time loop.
//
// What it is for
// --------------
// A simulator calls Predictor::step once per frame from a periodic task. What matters there
// is not the mean cost but the tail: how late the task wakes up and how long the step takes in
// the worst frames, and whether any frame misses its deadline. This program runs that loop:
//   * absolute-time sleeps: clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) to the next frame
//     start, so lateness never accumulates;
//   * pinned to one core (sched_setaffinity), SCHED_FIFO when the system permits it (reported
//     either way), memory locked (mlockall) when permitted;
//   * optionally (--load) a load generator pinned to another core: a thread that streams over
//     a 64 MB buffer and does floating-point work, at normal priority;
//   * per frame it records the wake-up lateness (wake time - frame start) and the compute time
//     of one Predictor<double>::step of Model II, C_L + C_m (bench_models.hpp), or of the
//     model of --model FILE.coef (a 1 Hz sine over the middle 90 % of its envelope for a pitch
//     model, +-0.2 rad for roll and yaw; at its reference airspeed);
//   * a frame overruns when the step finishes after the frame's deadline (the next frame's
//     start); frames skipped because of it count as overruns too.
// It prints a Markdown table: min, p50, p99, p99.9, max for both, and the overrun count.
//
// Usage
// -----
//   hil [--rate-hz 1000,10000] [--seconds 10] [--load] [--cpu 1] [--load-cpu 0]
//       [--wait sleep|spin] [--model FILE.coef]
// --wait spin replaces the sleep by a busy-wait on the clock: a diagnostic that separates the
// operating system's (here: the hypervisor's) wake-up latency from the step's own cost.
//
// Warnings
// --------
// 1. The compute time includes one clock_gettime (vDSO, a few tens of ns; the table's header
//    line prints its measured cost) and is wall time: a preemption inside the step shows as
//    compute time, which is what a real-time task would suffer.
// 2. On a shared virtual machine the hypervisor can steal the vCPU at any time; such a steal
//    shows up as lateness or compute time and is not the runtime's cost.
// 3. Linux only (clock_nanosleep, sched_setaffinity, SCHED_FIFO).
#include <errno.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "bench_models.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"

namespace ib = indicial::bench;

namespace {

using Ns = std::int64_t;

Ns now_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<Ns>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

timespec to_timespec(Ns t) {
  timespec ts;
  ts.tv_sec = static_cast<time_t>(t / 1000000000LL);
  ts.tv_nsec = static_cast<long>(t % 1000000000LL);
  return ts;
}

bool pin_to_cpu(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return sched_setaffinity(0, sizeof set, &set) == 0;  // 0: the calling thread
}

// How the loop waits for the next frame start.
enum class WaitMode : int {
  sleep = 0,  // clock_nanosleep(TIMER_ABSTIME): the normal periodic task
  spin = 1,   // busy-wait on CLOCK_MONOTONIC: burns the core, removes the OS wake-up path
};

struct Options {
  std::vector<double> rates_hz{1000.0, 10000.0};
  double seconds = 10.0;
  bool load = false;
  int cpu = 1;
  int load_cpu = 0;
  WaitMode wait = WaitMode::sleep;
  std::string model_path;  // --model: a coefficient file instead of the built-in Model II
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "hil: %s\nusage: hil [--rate-hz R1,R2,...] [--seconds S] [--load] [--cpu N] "
               "[--load-cpu M] [--wait sleep|spin] [--model FILE.coef]\n",
               why);
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(("missing value after " + a).c_str());
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      usage("periodic Predictor::step loop; prints a Markdown table of timing percentiles");
    } else if (a == "--rate-hz") {
      o.rates_hz.clear();
      std::string v = value();
      std::size_t pos = 0;
      while (pos <= v.size()) {
        const std::size_t comma = v.find(',', pos);
        const std::string item = v.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
        const double r = std::atof(item.c_str());
        if (!(r > 0.0 && r <= 100000.0)) usage("--rate-hz wants rates in (0, 100000]");
        o.rates_hz.push_back(r);
        if (comma == std::string::npos) break;
        pos = comma + 1;
      }
    } else if (a == "--seconds") {
      o.seconds = std::atof(value().c_str());
      if (!(o.seconds > 0.0 && o.seconds <= 3600.0)) usage("--seconds wants (0, 3600]");
    } else if (a == "--wait") {
      const std::string v = value();
      if (v == "sleep") o.wait = WaitMode::sleep;
      else if (v == "spin") o.wait = WaitMode::spin;
      else usage("--wait wants sleep or spin");
    } else if (a == "--model") {
      o.model_path = value();
    } else if (a == "--load") {
      o.load = true;
    } else if (a == "--cpu") {
      o.cpu = std::atoi(value().c_str());
    } else if (a == "--load-cpu") {
      o.load_cpu = std::atoi(value().c_str());
    } else {
      usage(("unknown option " + a).c_str());
    }
  }
  return o;
}

// The load generator: memory streaming (evicts the shared L3, loads the memory bus) mixed with
// floating-point work, until told to stop.
void load_generator(int cpu, std::atomic<bool>* stop, std::atomic<bool>* pinned) {
  pinned->store(pin_to_cpu(cpu));
  std::vector<double> buffer(std::size_t{8} << 20, 1.0);  // 64 MB
  double acc = 0.0;
  std::size_t i = 0;
  while (!stop->load(std::memory_order_relaxed)) {
    for (int k = 0; k < 4096; ++k) {
      buffer[i] = buffer[i] * 1.0000001 + std::sqrt(acc + 1.0);
      acc += buffer[i];
      i += 8;  // one cache line per access
      if (i >= buffer.size()) i = (i + 1) % 8;
    }
  }
  volatile double sink = acc;
  (void)sink;
}

struct Stats {
  Ns min, p50, p99, p999, max;
};

Stats stats_of(std::vector<Ns>& v) {
  std::sort(v.begin(), v.end());
  auto at = [&](double q) {
    const std::size_t idx = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) ;
    return v[std::min(v.size() - 1, idx == 0 ? 0 : idx - 1)];
  };
  return Stats{v.front(), at(0.5), at(0.99), at(0.999), v.back()};
}

struct RunResult {
  double rate_hz;
  std::size_t frames;
  Stats compute;
  Stats lateness;
  std::size_t overruns;
  std::size_t bad_status;
};

// The model a loop steps: the built-in Model II, or --model's file (its text, read up front).
struct LoopModel {
  std::string text;  // empty: Model II
  std::string label = "Model II, C_L + C_m";
};

LoopModel read_loop_model(const std::string& path) {
  LoopModel m;
  if (path.empty()) return m;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    std::fprintf(stderr, "hil: %s: is a directory, expected a coefficient file (.coef)\n", path.c_str());
    std::exit(1);
  }
  FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    std::fprintf(stderr, "hil: %s: cannot open file (does it exist?)\n", path.c_str());
    std::exit(1);
  }
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, f)) > 0;) m.text.append(buffer, n);
  std::fclose(f);
  m.label = path;
  return m;
}

RunResult run_loop(double rate_hz, double seconds, WaitMode wait, const LoopModel& lm) {
  indicial::Predictor<double> predictor;
  indicial::ParseDiagnostic diag;
  const indicial::LoadStatus st = lm.text.empty()
                                      ? predictor.load(ib::make_model_set<double>(ib::ModelKind::model_ii))
                                      : predictor.load(lm.text.data(), lm.text.size(), &diag);
  if (st != indicial::LoadStatus::ok) {
    std::fprintf(stderr, "hil: %s:%zu: %s (%s)\n", lm.label.c_str(), static_cast<std::size_t>(diag.line),
                 diag.reason, indicial::to_string(st));
    std::exit(1);
  }
  const indicial::ModelSet<double, indicial::DefaultCapacity>& set = predictor.model();
  const double airspeed_mps = lm.text.empty() ? ib::kAirspeedMps : set.airspeed_mps;
  const bool pitch = set.axis == indicial::Axis::pitch;
  const ib::Motion<double> motion =
      lm.text.empty() ? ib::Motion<double>(rate_hz)
                      : ib::Motion<double>(rate_hz, pitch ? 0.5 * (set.x_min_rad + set.x_max_rad) : 0.0,
                                           pitch ? 0.45 * (set.x_max_rad - set.x_min_rad) : 0.2, 1.0);
  predictor.reset(motion.angle_rad(0), airspeed_mps);
  indicial::Predictor<double>::Outputs out;
  const double dt_s = 1.0 / rate_hz;
  const Ns period = static_cast<Ns>(std::llround(1e9 / rate_hz));
  const std::size_t frames = static_cast<std::size_t>(std::llround(seconds * rate_hz));
  std::vector<Ns> compute(frames, 0), lateness(frames, 0);  // allocated and touched up front
  std::size_t overruns = 0, bad = 0, m = 1;
  double sink = 0.0;

  Ns next = now_ns() + 10 * period;
  std::size_t f = 0, r = 0;  // frames elapsed (run or skipped), frames run and recorded
  while (f < frames) {
    if (wait == WaitMode::sleep) {
      const timespec ts = to_timespec(next);
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
    } else {
      while (now_ns() < next) {
      }
    }
    const Ns wake = now_ns();
    const indicial::MotionInput in{motion.angle_rad(m), motion.rate_radps(m), airspeed_mps};
    const indicial::StepStatus s = predictor.step(in, dt_s, &out);
    const Ns done = now_ns();
    bad += (s != indicial::StepStatus::ok && s != indicial::StepStatus::angle_clamped);
    for (int c = 0; c < out.count; ++c) sink += out.value[c];
    if (++m == motion.size()) m = 0;
    compute[r] = done - wake;
    lateness[r] = wake - next;
    ++r;
    ++f;
    const Ns deadline = next + period;
    if (done > deadline) {
      // Why: the step finished after the frame's deadline. Frames whose start has already
      // passed are skipped (and counted) instead of being run back to back, as a real
      // periodic task that missed its slot would do.
      ++overruns;
      const Ns behind = (done - deadline) / period;  // whole frames lost beyond this one
      overruns += static_cast<std::size_t>(behind);
      next = deadline + (behind + 1) * period;
      f = std::min(frames, f + static_cast<std::size_t>(behind));
    } else {
      next = deadline;
    }
  }
  volatile double keep = sink;
  (void)keep;
  compute.resize(r);
  lateness.resize(r);
  return RunResult{rate_hz, r, stats_of(compute), stats_of(lateness), overruns, bad};
}

Ns clock_read_cost_ns() {
  const int n = 100000;
  const Ns t0 = now_ns();
  Ns last = 0;
  for (int i = 0; i < n; ++i) last = now_ns();
  return (last - t0) / n;
}

std::string us(Ns ns) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", static_cast<double>(ns) / 1000.0);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const long ncpu = sysconf(_SC_NPROCESSORS_ONLN);
  if (o.cpu < 0 || o.cpu >= ncpu) usage("--cpu is not an online CPU");

  std::atomic<bool> stop{false}, load_pinned{false};
  std::thread load_thread;
  if (o.load) {
    if (o.load_cpu < 0 || o.load_cpu >= ncpu || o.load_cpu == o.cpu)
      usage("--load-cpu must be an online CPU other than --cpu");
    load_thread = std::thread(load_generator, o.load_cpu, &stop, &load_pinned);
  }

  const bool pinned = pin_to_cpu(o.cpu);
  // Real-time priority for this thread only (the load thread stays SCHED_OTHER).
  // Not with --wait spin: a SCHED_FIFO task that never sleeps is stopped by the kernel's
  // real-time throttling (sched_rt_runtime_us, by default 50 ms of every second).
  sched_param sp{};
  sp.sched_priority = 80;
  const int fifo_err = o.wait == WaitMode::sleep
                           ? pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp)
                           : EPERM;
  const bool locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
  const int lock_err = locked ? 0 : errno;

  std::string policy =
      fifo_err == 0 ? "SCHED_FIFO priority 80"
      : o.wait == WaitMode::spin
          ? "SCHED_OTHER (not requested with --wait spin: real-time throttling)"
          : std::string("SCHED_OTHER (SCHED_FIFO refused: ") + std::strerror(fifo_err) + ")";
  std::vector<RunResult> results;
  const Ns clock_cost = clock_read_cost_ns();
  const LoopModel model = read_loop_model(o.model_path);
  for (double r : o.rates_hz) results.push_back(run_loop(r, o.seconds, o.wait, model));

  stop = true;
  if (load_thread.joinable()) load_thread.join();

  std::printf("HIL loop: Predictor<double>::step, %s, %g s per rate; "
              "pinned to CPU %d: %s; scheduling: %s; mlockall: %s; load: %s; wait: %s; "
              "clock_gettime cost ~%lld ns (included in compute).\n\n",
              model.label.c_str(), o.seconds, o.cpu, pinned ? "yes" : "FAILED", policy.c_str(),
              locked ? "yes" : std::strerror(lock_err),
              o.load ? (std::string("memory+FP thread on CPU ") + std::to_string(o.load_cpu) +
                        (load_pinned.load() ? "" : " (pinning FAILED)"))
                           .c_str()
                     : "none",
              o.wait == WaitMode::sleep ? "clock_nanosleep(TIMER_ABSTIME)" : "busy-wait (spin)",
              static_cast<long long>(clock_cost));
  std::printf("| rate | frames run | load | metric | min us | p50 us | p99 us | p99.9 us | max us | "
              "overruns | bad status |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const RunResult& r : results) {
    const char* load = o.load ? "loaded" : "idle";
    std::printf("| %g Hz | %zu | %s | compute | %s | %s | %s | %s | %s | %zu | %zu |\n", r.rate_hz,
                r.frames, load, us(r.compute.min).c_str(), us(r.compute.p50).c_str(),
                us(r.compute.p99).c_str(), us(r.compute.p999).c_str(), us(r.compute.max).c_str(),
                r.overruns, r.bad_status);
    std::printf("| %g Hz | %zu | %s | wake-up lateness | %s | %s | %s | %s | %s | | |\n", r.rate_hz,
                r.frames, load, us(r.lateness.min).c_str(), us(r.lateness.p50).c_str(),
                us(r.lateness.p99).c_str(), us(r.lateness.p999).c_str(),
                us(r.lateness.max).c_str());
  }
  return 0;
}
