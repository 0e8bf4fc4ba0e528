// firmware/cortex-m/host_check.cpp -- the host side of the Cortex-M replay
// (tools/run-cortex-m.sh): writes the reference motion the firmware replays, then compares
// the firmware's outputs with the same replay on the host, in float and in double.
//
//   host_check motion MOTION.bin
//   host_check compare MODEL.coef MOTION.bin TARGET.out.bin [--max-ulp N]
//
// compare exits 1 when a status differs or a float output differs by more than N ulp
// (default 0: bit-identical) from the host's Predictor<float>, and prints the largest
// differences from the host's Predictor<double>.
//
// The motion (replay_format.hpp):
//   segment 0, 1000 steps: the benchmarks' motion (bench/bench_models.hpp): alpha = 35 + 35
//     sin(2 pi t) deg, q its rate, dt = 1 ms, V = V_ref: the instruction counts compare with
//     the host's callgrind counts of the same model.
//   segment 1, 1000 steps: beyond the envelope at both ends (clamped), the airspeed changing
//     every step (+-30 %), dt jittering between 0.75 and 1.25 ms.
//   segment 2, 8 steps: refusals (NaN, Inf, dt <= 0, dt > 1 s, airspeed <= 0) between
//     ordinary steps: each status must match and leave the state as it was.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"
#include "replay_format.hpp"

namespace {

constexpr int max_coefficients = indicial::DefaultCapacity::max_coefficients;
using fw::MotionHeader;
using fw::MotionSample;
using fw::OutputRecord;

constexpr double pi = 3.14159265358979323846;
constexpr double reference_airspeed_mps = 17.667762;

std::vector<MotionSample> reference_motion(MotionHeader* h) {
  std::vector<MotionSample> m;
  const double amp_rad = 35.0 * pi / 180.0;
  m.push_back({amp_rad, amp_rad * 2 * pi, reference_airspeed_mps, 0.0});  // reset sample
  for (int i = 1; i <= 1000; ++i) {
    const double t = i * 1e-3;
    m.push_back({amp_rad + amp_rad * std::sin(2 * pi * t), amp_rad * 2 * pi * std::cos(2 * pi * t),
                 reference_airspeed_mps, 1e-3});
  }
  h->segment_end[0] = static_cast<std::uint32_t>(m.size());
  double t = 1.0;
  for (int i = 1; i <= 1000; ++i) {
    const double dt = 1e-3 * (1.0 + 0.25 * std::sin(0.37 * i));
    t += dt;
    const double w = 2 * pi * 1.5;
    const double center = 40.0 * pi / 180.0;
    const double amp = 45.0 * pi / 180.0;  // -5 .. 85 deg: clamps at both ends of -2.9 .. 74.5
    m.push_back({center + amp * std::sin(w * t), amp * w * std::cos(w * t),
                 reference_airspeed_mps * (1.0 + 0.3 * std::sin(2 * pi * 0.7 * t)), dt});
  }
  h->segment_end[1] = static_cast<std::uint32_t>(m.size());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const MotionSample ok{0.5, 0.1, 20.0, 1e-3};
  const MotionSample refusals[] = {{nan, 0.1, 20.0, 1e-3}, ok, {0.5, inf, 20.0, 1e-3},
                                   {0.5, 0.1, 20.0, 0.0},  ok, {0.5, 0.1, 20.0, 2.0},
                                   {0.5, 0.1, -3.0, 1e-3}, ok};
  for (const MotionSample& s : refusals) m.push_back(s);
  h->segment_end[2] = static_cast<std::uint32_t>(m.size());
  h->n_segments = 3;
  h->n_steps = static_cast<std::uint32_t>(m.size() - 1);
  std::memcpy(h->magic, "IMOTION1", 8);
  return m;
}

int write_motion(const char* path) {
  MotionHeader h{};
  const std::vector<MotionSample> m = reference_motion(&h);
  std::FILE* f = std::fopen(path, "wb");
  if (f == nullptr) {
    std::fprintf(stderr, "host_check: cannot write %s\n", path);
    return 2;
  }
  const bool ok = std::fwrite(&h, sizeof h, 1, f) == 1 &&
                  std::fwrite(m.data(), sizeof(MotionSample), m.size(), f) == m.size();
  if (std::fclose(f) != 0 || !ok) {
    std::fprintf(stderr, "host_check: cannot write %s\n", path);
    return 2;
  }
  return 0;
}

std::string read_all(const char* path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "host_check: cannot read %s\n", path);
    std::exit(2);
  }
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Distance in units in the last place between two finite floats of any signs.
std::int64_t ulp_distance(float a, float b) {
  const auto ordered = [](float v) {
    std::int32_t i;
    std::memcpy(&i, &v, sizeof i);
    return i < 0 ? static_cast<std::int64_t>(INT32_MIN) - i : static_cast<std::int64_t>(i);
  };
  const std::int64_t d = ordered(a) - ordered(b);
  return d < 0 ? -d : d;
}

template <class Scalar>
struct HostRun {
  int count = 0;  // the model's coefficients
  std::vector<int> status;
  std::vector<Scalar> value;  // n_steps + 1 rows of max_coefficients
};

template <class Scalar>
HostRun<Scalar> run_host(const std::string& text, const std::vector<MotionSample>& m) {
  indicial::Predictor<Scalar> p;
  indicial::ParseDiagnostic diag;
  if (p.load(text.data(), text.size(), &diag) != indicial::LoadStatus::ok) {
    std::fprintf(stderr, "host_check: the model is refused: line %zu: %s\n", diag.line, diag.reason);
    std::exit(2);
  }
  HostRun<Scalar> r;
  r.count = p.coefficient_count();
  r.value.assign(m.size() * max_coefficients, Scalar(0));
  r.status.push_back(static_cast<int>(p.reset(m[0].angle_rad, m[0].airspeed_mps)));
  typename indicial::Predictor<Scalar>::Outputs out;
  for (std::size_t k = 1; k < m.size(); ++k) {
    const indicial::MotionInput in{m[k].angle_rad, m[k].rate_radps, m[k].airspeed_mps};
    r.status.push_back(static_cast<int>(p.step(in, m[k].dt_s, &out)));
    for (int c = 0; c < max_coefficients; ++c) r.value[k * max_coefficients + c] = out.value[c];
  }
  return r;
}

int compare(const char* coef_path, const char* motion_path, const char* target_path, long max_ulp) {
  const std::string text = read_all(coef_path);
  const std::string motion_bytes = read_all(motion_path);
  const std::string target_bytes = read_all(target_path);
  MotionHeader h{};
  if (motion_bytes.size() < sizeof h) return std::fprintf(stderr, "host_check: short motion\n"), 2;
  std::memcpy(&h, motion_bytes.data(), sizeof h);
  const std::size_t n = h.n_steps + 1;
  if (motion_bytes.size() != sizeof h + n * sizeof(MotionSample) || target_bytes.size() != n * sizeof(OutputRecord))
    return std::fprintf(stderr, "host_check: motion and target output sizes do not match\n"), 2;
  std::vector<MotionSample> m(n);
  std::memcpy(m.data(), motion_bytes.data() + sizeof h, n * sizeof(MotionSample));
  std::vector<OutputRecord> target(n);
  std::memcpy(target.data(), target_bytes.data(), n * sizeof(OutputRecord));
  const HostRun<float> hf = run_host<float>(text, m);
  const HostRun<double> hd = run_host<double>(text, m);
  int status_mismatches = 0;
  std::int64_t worst_ulp = 0;
  double worst_abs = 0.0;
  double worst_rel = 0.0;
  double host_float_worst_abs = 0.0;
  int stepped = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (target[k].status != hf.status[k] || target[k].status != hd.status[k]) {
      if (++status_mismatches <= 5)
        std::fprintf(stderr, "host_check: step %zu: status %d on the target, %d host float, %d host double\n", k,
                     target[k].status, hf.status[k], hd.status[k]);
      continue;
    }
    if (k == 0 || (target[k].status != 0 && target[k].status != 1)) continue;
    ++stepped;
    for (int c = 0; c < hf.count; ++c) {
      const float t = target[k].value[c];
      const float f = hf.value[k * max_coefficients + c];
      const double d = hd.value[k * max_coefficients + c];
      worst_ulp = std::max(worst_ulp, ulp_distance(t, f));
      const double e = std::fabs(static_cast<double>(t) - d);
      worst_abs = std::max(worst_abs, e);
      worst_rel = std::max(worst_rel, e / std::max(std::fabs(d), 0.01));
      host_float_worst_abs = std::max(host_float_worst_abs, std::fabs(static_cast<double>(f) - d));
    }
  }
  std::printf("steps compared: %d (%d statuses differ)\n", stepped, status_mismatches);
  std::printf("target float vs host float: max %lld ulp\n", static_cast<long long>(worst_ulp));
  std::printf("target float vs host double: max abs %.3g, max rel %.3g (relative to max(|value|, 0.01))\n",
              worst_abs, worst_rel);
  std::printf("host float vs host double: max abs %.3g\n", host_float_worst_abs);
  if (status_mismatches > 0 || worst_ulp > max_ulp) {
    std::fprintf(stderr, "host_check: FAILED (statuses differ or more than %ld ulp)\n", max_ulp);
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "motion") == 0) return write_motion(argv[2]);
  if ((argc == 5 || argc == 7) && std::strcmp(argv[1], "compare") == 0) {
    long max_ulp = 0;
    if (argc == 7 && std::strcmp(argv[5], "--max-ulp") == 0) max_ulp = std::strtol(argv[6], nullptr, 10);
    return compare(argv[2], argv[3], argv[4], max_ulp);
  }
  std::fprintf(stderr,
               "usage: host_check motion MOTION.bin\n"
               "       host_check compare MODEL.coef MOTION.bin TARGET.out.bin [--max-ulp N]\n");
  return 2;
}
