// bench/bench_step.cpp -- the cost of one runtime step against its floor and its peers.
//
// What it measures (all in ONE binary and ONE run, so ratios share the machine's state)
// ----------------------------------------------------------------------------------------
// For C_L + C_m in pitch (bench_models.hpp: Model I, Model II, two lags; double and float),
// at 1 kHz (dt = 1 ms) on the report's 35 +/- 35 deg, 1 Hz motion:
//   step/<model>/<scalar>      indicial::Predictor::step (runtime/include/indicial/runtime.hpp)
//   state/<model>/<scalar>     indicial::step(model, State, ...): the stateless core on a
//                              shared RuntimeModel (what Predictor::step wraps)
//   c/<model>/double           indicial_step, the C interface (indicial/indicial.h)
//   state/stall2/<scalar>      indicial::step(model, FamilyState, ...) of Model II with both
//   step/stall2/double,        dynamic-stall families on C_L and C_m (issue 22); its goal is
//   c/stall2/double            state/stall2/double <= 2 x state/model2/double in one run
//   state/stall2h/double       state/stall2/double's model with the static hysteresis (dxr = 3
//                              deg on both coefficients; model.hpp): every family there is
//   model/<model>/<scalar>     advance_lags + coefficient_output straight from model.hpp, i.e.
//                              the step without the runtime's input checks and bookkeeping
//   floor/<model>/<scalar>     only the work no implementation can avoid: per coefficient the
//                              static polynomial, the rotary polynomial and the antiderivative
//                              A(x1) at the NEW angle, and per lag the antiderivative B_j(x1)
//                              (the update averages b_j over the angle swept) and one exp().
//                              The values at the old angle are not in the floor: they were
//                              computed the step before (the runtime keeps them)
//   update/<model>/<scalar>    the floor plus the rest of the model's update in its minimal
//                              form (the angle-mean decay, phi1, the lag update, the output
//                              sum from kept values): the same model work as the step without
//                              any of the runtime's checks, clamp, cache or commit copy
//   rk4/model2/double          classic RK4 of the lag ODE (lag_derivatives) at the same dt,
//                              angle linear between samples: what a user might write instead
//   conv1s/model2/double       direct quadrature of the convolution integral of eq. 4b (report
//   conv10s/model2/double      eq. 15) over the whole history: 1000 and 10000 samples at 1 kHz
//
// How the dependency chain is kept (and checked)
// ----------------------------------------------
// Every iteration's input angle is the motion sample plus 1e-9 times the previous iteration's
// output, so step k+1 cannot start before step k has finished, and the output goes through
// benchmark::DoNotOptimize. A compiler that dropped the work would make the time per step
// collapse to the loop overhead (~1 ns); run_all.sh instead checks that (a) the floor's time
// is consistent with its exp() count, (b) the conv10s/conv1s ratio is ~10 (time scales with the
// work), and (c) callgrind instruction counts per step (--callgrind mode below) are in line
// with the measured times. The disassembly can be inspected with
//   objdump -d --no-show-raw-insn bench_step | grep -c 'call.*<exp'
//
// Heap allocations: alloc_counter.hpp replaces malloc and operator new in this binary; every
// benchmark reports allocs_per_step over its timed loop (the goal is exactly 0).
//
// --callgrind NAME N: runs N steps of one variant outside Google Benchmark between
// CALLGRIND_START/STOP_INSTRUMENTATION, for `valgrind --tool=callgrind --collect-atstart=no`.
#include <benchmark/benchmark.h>
#include <valgrind/callgrind.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "bench_models.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/indicial.h"
#include "indicial/model.hpp"
#include "indicial/runtime.hpp"

namespace ib = indicial::bench;
using ib::Cap;
using ib::ModelKind;

namespace {

constexpr double kDtS = 1e-3;       // 1 kHz
constexpr double kChainGain = 1e-9; // output -> next input: keeps the dependency chain

// ------------------------------------------------------------------------------------------
// step/: the product, indicial::Predictor::step with its input checks, clamping, copy-then-
// commit state and finite-result checks.
// ------------------------------------------------------------------------------------------
template <class Scalar>
class PredictorStepper {
 public:
  explicit PredictorStepper(ModelKind kind) {
    const indicial::LoadStatus s = predictor_.load(ib::make_model_set<double>(kind));
    if (s != indicial::LoadStatus::ok) {
      std::fprintf(stderr, "Predictor::load refused the benchmark model (status %d)\n",
                   static_cast<int>(s));
      std::abort();
    }
  }
  void reset(Scalar x_rad) { predictor_.reset(static_cast<double>(x_rad), ib::kAirspeedMps); }
  Scalar step(Scalar x1_rad, Scalar q_radps, Scalar dt_s) {
    const indicial::MotionInput in{static_cast<double>(x1_rad), static_cast<double>(q_radps),
                                   ib::kAirspeedMps};
    const indicial::StepStatus s = predictor_.step(in, static_cast<double>(dt_s), &out_);
    // Counted, not branched on in a way that could skip work: every status but ok means the
    // benchmark is broken (the motion stays inside the envelope).
    bad_steps_ += (s != indicial::StepStatus::ok);
    return out_.value[0] + out_.value[1];
  }
  unsigned long long bad_steps() const { return bad_steps_; }

 private:
  indicial::Predictor<Scalar, Cap> predictor_;
  typename indicial::Predictor<Scalar, Cap>::Outputs out_;
  unsigned long long bad_steps_ = 0;
};

// ------------------------------------------------------------------------------------------
// state/: the stateless core, indicial::step(model, State, ...) on a shared RuntimeModel (what
// Predictor::step wraps; the checks, clamp and copy-then-commit are the same).
// c/: the same through the C interface (indicial_step, indicial/indicial.h).
// ------------------------------------------------------------------------------------------
template <class Scalar, class St = indicial::State<Scalar, Cap>>
class StateStepper {
 public:
  explicit StateStepper(ModelKind kind) : model_(std::make_unique<indicial::RuntimeModel<Scalar, Cap>>()) {
    if (indicial::make_runtime_model(ib::make_model_set<double>(kind), model_.get()) !=
        indicial::LoadStatus::ok)
      std::abort();
  }
  void reset(Scalar x_rad) { indicial::reset(*model_, state_, static_cast<double>(x_rad), ib::kAirspeedMps); }
  Scalar step(Scalar x1_rad, Scalar q_radps, Scalar dt_s) {
    const indicial::MotionInput in{static_cast<double>(x1_rad), static_cast<double>(q_radps),
                                   ib::kAirspeedMps};
    const indicial::StepStatus s = indicial::step(*model_, state_, in, static_cast<double>(dt_s), out_);
    bad_steps_ += (s != indicial::StepStatus::ok);
    return out_[0] + out_[1];
  }
  unsigned long long bad_steps() const { return bad_steps_; }

 private:
  std::unique_ptr<indicial::RuntimeModel<Scalar, Cap>> model_;
  St state_;
  Scalar out_[Cap::max_coefficients] = {};
  unsigned long long bad_steps_ = 0;
};

class CStepper {
 public:
  explicit CStepper(ModelKind kind) : model_(indicial_model_bytes() / sizeof(double) + 1) {
    char text[16384];
    std::size_t n = 0;
    if (indicial::write_coef_file(ib::make_model_set<double>(kind), text, sizeof text, &n) !=
            indicial::WriteStatus::ok ||
        indicial_model_load(model_.data(), text, n, nullptr, 0) != INDICIAL_OK)
      std::abort();
    state_.resize(indicial_state_bytes(model_.data()) / sizeof(double) + 1);
  }
  void reset(double x_rad) { indicial_reset(model_.data(), state_.data(), x_rad, ib::kAirspeedMps); }
  double step(double x1_rad, double q_radps, double dt_s) {
    const int s = indicial_step(model_.data(), state_.data(), x1_rad, q_radps, ib::kAirspeedMps, dt_s, out_);
    bad_steps_ += (s != INDICIAL_OK);
    return out_[0] + out_[1];
  }
  unsigned long long bad_steps() const { return bad_steps_; }

 private:
  std::vector<double> model_;  // double-aligned storage, as indicial.h asks
  std::vector<double> state_;
  double out_[3] = {};
  unsigned long long bad_steps_ = 0;
};

template <class Stepper>
unsigned long long bad_steps_of(const Stepper&) { return 0; }
template <class Scalar>
unsigned long long bad_steps_of(const PredictorStepper<Scalar>& s) { return s.bad_steps(); }
template <class Scalar>
unsigned long long bad_steps_of(const StateStepper<Scalar>& s) { return s.bad_steps(); }
inline unsigned long long bad_steps_of(const CStepper& s) { return s.bad_steps(); }

// ------------------------------------------------------------------------------------------
// model/: the update exactly as model.hpp writes it (what the runtime's step wraps).
// ------------------------------------------------------------------------------------------
template <class Scalar>
class ModelStepper {
 public:
  explicit ModelStepper(ModelKind kind) : set_(ib::make_model_set<Scalar>(kind)) {}
  void reset(Scalar x_rad) {
    x_prev_ = x_rad;
    for (int c = 0; c < set_.n_coefficients; ++c)
      indicial::steady_state(set_.coefficients[c], x_rad, y_[c]);
  }
  Scalar step(Scalar x1_rad, Scalar q_radps, Scalar dt_s) {
    const indicial::StepGeometry<Scalar> g{x_prev_, x1_rad, x_prev_, x1_rad, dt_s, Scalar(1)};
    const Scalar l_over_v_s = Scalar(set_.reference_length_m / set_.airspeed_mps);
    Scalar sum = Scalar(0);
    for (int c = 0; c < set_.n_coefficients; ++c) {
      indicial::advance_lags(set_.coefficients[c], g, y_[c]);
      sum += indicial::coefficient_output(set_.coefficients[c], x1_rad, q_radps, l_over_v_s,
                                          y_[c]);
    }
    x_prev_ = x1_rad;
    return sum;
  }

 private:
  indicial::ModelSet<Scalar, Cap> set_;
  Scalar y_[Cap::max_coefficients][Cap::max_lags] = {};
  Scalar x_prev_ = Scalar(0);
};

// ------------------------------------------------------------------------------------------
// floor/: the unavoidable evaluations at the new angle, and one exp per lag and coefficient.
// ------------------------------------------------------------------------------------------
// The floor's spline evaluations, out of line as the step's are (model.hpp's spline_value_with
// and spline_antiderivative_with are called, not inlined, in the runtime's step). Why: GCC
// inlined some of the floor's calls and not others depending on unrelated code in the header
// (the count moved between 732 and 759 instructions per step with the floor's code unchanged);
// out of line (one call each: flatten inlines model.hpp's body into the wrapper), the floor is
// the same work in the same form as the step's.
template <class Scalar, int P, int K>
__attribute__((noinline, flatten)) Scalar floor_value(const indicial::Spline<Scalar, P, K>& s, Scalar x) {
  return indicial::spline_value(s, x);
}
template <class Scalar, int P, int K>
__attribute__((noinline, flatten)) Scalar floor_antiderivative(const indicial::Spline<Scalar, P, K>& s, Scalar x) {
  return indicial::spline_antiderivative(s, x);
}

template <class Scalar>
class FloorStepper {
 public:
  explicit FloorStepper(ModelKind kind) : set_(ib::make_model_set<Scalar>(kind)) {}
  void reset(Scalar) {}
  Scalar step(Scalar x1_rad, Scalar q_radps, Scalar dt_s) {
    using std::exp;
    Scalar sum = Scalar(0);
    for (int c = 0; c < set_.n_coefficients; ++c) {
      const auto& m = set_.coefficients[c];
      sum += floor_value(m.static_curve.polynomial, x1_rad);
      sum += floor_value(m.rotary, x1_rad) * q_radps;
      sum += floor_antiderivative(m.a, x1_rad);
      for (int j = 0; j < m.n_lags; ++j)
        sum += exp(-floor_antiderivative(m.lags[j].b, x1_rad) * dt_s);
    }
    return sum;
  }

 private:
  indicial::ModelSet<Scalar, Cap> set_;
};

// ------------------------------------------------------------------------------------------
// update/: the floor plus the rest of the model's update in its minimal form -- what any
// implementation of this discretisation must also compute once the floor's evaluations are
// done: per lag the angle-mean decay (B_j(x1) - B_j(x0)) / (x1 - x0) from the kept B_j(x0),
// phi1 = (1 - e^-z) / z, the update y = e^-z y + phi1 drive from the kept A(x0) (both quotients
// as model.hpp takes them: times a reciprocal computed off the dependent chain, 1 / (x1 - x0)
// before B_j(x1) is known and 1 / z while exp(-z) runs), and per coefficient the output static + (l/V) rotary q + sum y. Nothing else: no input checks, no
// clamp, no airspeed terms (the reference airspeed), no copy for commit-if-finite, and not
// even the two branches the model needs for a correct result at dx -> 0 and z -> 0 (this
// motion never takes them): a lower bound on the step's own work, by construction. The floor
// above leaves that arithmetic out (and with it the loads of the kept values), so step /
// floor counts it as overhead; step / update is what the runtime's checks and bookkeeping
// cost. check_update_matches_model checks that it computes the step's numbers.
// ------------------------------------------------------------------------------------------
template <class Scalar>
class UpdateStepper {
 public:
  explicit UpdateStepper(ModelKind kind) : set_(ib::make_model_set<Scalar>(kind)) {}
  void reset(Scalar x_rad) {
    x_prev_ = x_rad;
    for (int c = 0; c < set_.n_coefficients; ++c) {
      const auto& m = set_.coefficients[c];
      indicial::steady_state(m, x_rad, y_[c]);
      a0_[c] = floor_antiderivative(m.a, x_rad);
      for (int j = 0; j < m.n_lags; ++j) b0_[c][j] = floor_antiderivative(m.lags[j].b, x_rad);
    }
  }
  Scalar step(Scalar x1_rad, Scalar q_radps, Scalar dt_s) {
    using std::exp;
    const Scalar l_over_v_s = Scalar(set_.reference_length_m / set_.airspeed_mps);
    const Scalar inv_dx = Scalar(1) / (x1_rad - x_prev_);
    Scalar sum = Scalar(0);
    for (int c = 0; c < set_.n_coefficients; ++c) {
      const auto& m = set_.coefficients[c];
      const Scalar a1 = floor_antiderivative(m.a, x1_rad);
      const Scalar forcing = a1 - a0_[c];
      a0_[c] = a1;
      Scalar out = floor_value(m.static_curve.polynomial, x1_rad) +
                   l_over_v_s * floor_value(m.rotary, x1_rad) * q_radps;
      for (int j = 0; j < m.n_lags; ++j) {
        const Scalar b1 = floor_antiderivative(m.lags[j].b, x1_rad);
        const Scalar z = (b1 - b0_[c][j]) * inv_dx * dt_s;
        b0_[c][j] = b1;
        const Scalar e = exp(-z);
        const Scalar drive = j == 0 ? Scalar(-forcing + m.con * dt_s) : Scalar(-m.lags[j].gain * forcing);
        y_[c][j] = e * y_[c][j] + (Scalar(1) - e) * (Scalar(1) / z) * drive;
        out += y_[c][j];
      }
      sum += out;
    }
    x_prev_ = x1_rad;
    return sum;
  }

 private:
  indicial::ModelSet<Scalar, Cap> set_;
  Scalar y_[Cap::max_coefficients][Cap::max_lags] = {};
  Scalar a0_[Cap::max_coefficients] = {};
  Scalar b0_[Cap::max_coefficients][Cap::max_lags] = {};
  Scalar x_prev_ = Scalar(0);
};

// ------------------------------------------------------------------------------------------
// rk4/: classic fourth-order Runge-Kutta of y' = -b(x) y - c a(x) x' (lag_derivatives), with
// the angle linear between samples (x' constant over the step). Four right-hand sides per step.
// ------------------------------------------------------------------------------------------
template <class Scalar>
class Rk4Stepper {
 public:
  explicit Rk4Stepper(ModelKind kind) : set_(ib::make_model_set<Scalar>(kind)) {}
  void reset(Scalar x_rad) {
    x_prev_ = x_rad;
    for (int c = 0; c < set_.n_coefficients; ++c)
      indicial::steady_state(set_.coefficients[c], x_rad, y_[c]);
  }
  Scalar step(Scalar x1_rad, Scalar q_radps, Scalar dt_s) {
    constexpr int L = Cap::max_lags;
    const Scalar l_over_v_s = Scalar(set_.reference_length_m / set_.airspeed_mps);
    const Scalar xdot = (x1_rad - x_prev_) / dt_s;
    const Scalar xm = Scalar(0.5) * (x_prev_ + x1_rad);
    const Scalar one = Scalar(1);
    Scalar sum = Scalar(0);
    for (int c = 0; c < set_.n_coefficients; ++c) {
      const auto& m = set_.coefficients[c];
      Scalar* y = y_[c];
      Scalar k1[L], k2[L], k3[L], k4[L], t[L];
      indicial::lag_derivatives(m, x_prev_, x_prev_, xdot, one, y, k1);
      for (int j = 0; j < m.n_lags; ++j) t[j] = y[j] + Scalar(0.5) * dt_s * k1[j];
      indicial::lag_derivatives(m, xm, xm, xdot, one, t, k2);
      for (int j = 0; j < m.n_lags; ++j) t[j] = y[j] + Scalar(0.5) * dt_s * k2[j];
      indicial::lag_derivatives(m, xm, xm, xdot, one, t, k3);
      for (int j = 0; j < m.n_lags; ++j) t[j] = y[j] + dt_s * k3[j];
      indicial::lag_derivatives(m, x1_rad, x1_rad, xdot, one, t, k4);
      for (int j = 0; j < m.n_lags; ++j)
        y[j] += dt_s / Scalar(6) * (k1[j] + Scalar(2) * (k2[j] + k3[j]) + k4[j]);
      sum += indicial::coefficient_output(m, x1_rad, q_radps, l_over_v_s, y);
    }
    x_prev_ = x1_rad;
    return sum;
  }

 private:
  indicial::ModelSet<Scalar, Cap> set_;
  Scalar y_[Cap::max_coefficients][Cap::max_lags] = {};
  Scalar x_prev_ = Scalar(0);
};

// ------------------------------------------------------------------------------------------
// conv/: eq. 15 evaluated directly at every step over the whole (fixed-length) history:
//   y(t_n) = - sum_k exp(-(B_n - B_k)) a(x_k) x'_k dt,   B_n = integral_0^t_n b1(x) dt
// with B accumulated by the trapezoid rule. The history is a ring of `history` samples, so the
// cost per step is that of a run that has been going for history * dt seconds. One exp per
// history sample and coefficient: this is the cost a user pays without the recursive state.
// ------------------------------------------------------------------------------------------
template <class Scalar>
class ConvolutionStepper {
 public:
  ConvolutionStepper(ModelKind kind, std::size_t history)
      : set_(ib::make_model_set<Scalar>(kind)), n_(history) {
    for (int c = 0; c < set_.n_coefficients; ++c) {
      cum_b_[c].assign(n_, Scalar(0));
      forcing_[c].assign(n_, Scalar(0));
    }
  }
  void reset(Scalar x_rad) { x_prev_ = x_rad; }
  Scalar step(Scalar x1_rad, Scalar q_radps, Scalar dt_s) {
    using std::exp;
    const Scalar l_over_v_s = Scalar(set_.reference_length_m / set_.airspeed_mps);
    Scalar sum = Scalar(0);
    for (int c = 0; c < set_.n_coefficients; ++c) {
      const auto& m = set_.coefficients[c];
      const Scalar b0 = indicial::spline_value(m.lags[0].b, x_prev_);
      const Scalar b1 = indicial::spline_value(m.lags[0].b, x1_rad);
      b_total_[c] += Scalar(0.5) * (b0 + b1) * dt_s;
      cum_b_[c][head_] = b_total_[c];
      forcing_[c][head_] = indicial::spline_value(m.a, x1_rad) * q_radps * dt_s;
      const Scalar* cb = cum_b_[c].data();
      const Scalar* f = forcing_[c].data();
      const Scalar bn = b_total_[c];
      Scalar y = Scalar(0);
      for (std::size_t k = 0; k < n_; ++k) y -= exp(cb[k] - bn) * f[k];
      sum += indicial::quasi_steady_output(m, x1_rad, q_radps, l_over_v_s) + y;
    }
    if (++head_ == n_) head_ = 0;
    x_prev_ = x1_rad;
    return sum;
  }

 private:
  indicial::ModelSet<Scalar, Cap> set_;
  std::size_t n_;
  std::size_t head_ = 0;
  std::vector<Scalar> cum_b_[Cap::max_coefficients];
  std::vector<Scalar> forcing_[Cap::max_coefficients];
  Scalar b_total_[Cap::max_coefficients] = {};
  Scalar x_prev_ = Scalar(0);
};

// ------------------------------------------------------------------------------------------
// The timed loop shared by every variant.
// ------------------------------------------------------------------------------------------
template <class Scalar, class Stepper>
void run_chain(benchmark::State& state, Stepper& stepper, std::size_t warmup_steps) {
  const ib::Motion<Scalar> motion(1.0 / kDtS);
  const std::size_t n = motion.size();
  std::vector<Scalar> angle(n), rate(n);
  for (std::size_t i = 0; i < n; ++i) {
    angle[i] = motion.angle_rad(i);
    rate[i] = motion.rate_radps(i);
  }
  const Scalar dt_s = Scalar(kDtS);
  const Scalar chain = Scalar(kChainGain);
  stepper.reset(angle[0]);
  Scalar prev = Scalar(0);
  std::size_t i = 1;
  // Untimed warm-up: fills the convolution history, settles the lag states.
  for (std::size_t w = 0; w < warmup_steps; ++w) {
    prev = stepper.step(angle[i] + chain * prev, rate[i], dt_s);
    if (++i == n) i = 0;
  }
  const unsigned long long allocs_before = ib::allocation_count();
  for (auto _ : state) {
    prev = stepper.step(angle[i] + chain * prev, rate[i], dt_s);
    benchmark::DoNotOptimize(prev);
    if (++i == n) i = 0;
  }
  const unsigned long long allocs = ib::allocation_count() - allocs_before;
  state.counters["allocs_per_step"] =
      static_cast<double>(allocs) / static_cast<double>(state.iterations());
  if (!std::isfinite(static_cast<double>(prev))) state.SkipWithError("non-finite output");
  if (bad_steps_of(stepper) != 0) state.SkipWithError("Predictor::step returned a status other than ok");
}

template <class Scalar, class Stepper, class... Args>
void register_variant(const std::string& name, std::size_t warmup, Args... args) {
  benchmark::RegisterBenchmark(name.c_str(), [=](benchmark::State& state) {
    auto stepper = std::make_unique<Stepper>(args...);
    run_chain<Scalar>(state, *stepper, warmup);
  });
}

template <class Scalar>
const char* scalar_name();
template <>
const char* scalar_name<double>() { return "double"; }
template <>
const char* scalar_name<float>() { return "float"; }

template <class Scalar>
void register_scalar() {
  const std::string s = scalar_name<Scalar>();
  for (ModelKind k : {ModelKind::model_i, ModelKind::model_ii, ModelKind::two_lags}) {
    const std::string m = ib::model_kind_name(k);
    register_variant<Scalar, PredictorStepper<Scalar>>("step/" + m + "/" + s, 1000, k);
    register_variant<Scalar, StateStepper<Scalar>>("state/" + m + "/" + s, 1000, k);
    register_variant<Scalar, ModelStepper<Scalar>>("model/" + m + "/" + s, 1000, k);
    register_variant<Scalar, FloorStepper<Scalar>>("floor/" + m + "/" + s, 1000, k);
    register_variant<Scalar, UpdateStepper<Scalar>>("update/" + m + "/" + s, 1000, k);
  }
}

// Model II with both dynamic-stall families (issue 22): the stateless core on a FamilyState,
// the Predictor and the C interface.
void register_stall() {
  const ModelKind k = ModelKind::model_ii_stall;
  register_variant<double, StateStepper<double, indicial::FamilyState<double, Cap>>>("state/stall2/double", 1000, k);
  register_variant<float, StateStepper<float, indicial::FamilyState<float, Cap>>>("state/stall2/float", 1000, k);
  register_variant<double, PredictorStepper<double>>("step/stall2/double", 1000, k);
  register_variant<double, CStepper>("c/stall2/double", 1000, k);
  const ModelKind h = ModelKind::model_ii_stall_hysteresis;
  register_variant<double, StateStepper<double, indicial::FamilyState<double, Cap>>>("state/stall2h/double", 1000, h);
}

// Checks that Predictor::step (double) gives Stepper's numbers within relative tolerance tol
// over 5000 steps of each model, so that step/ and Stepper's variant time the same computation.
template <class Stepper>
bool step_matches(const char* variant, double tol) {
  for (ModelKind k : {ModelKind::model_i, ModelKind::model_ii, ModelKind::two_lags}) {
    Stepper a(k);
    PredictorStepper<double> b(k);
    const ib::Motion<double> motion(1000.0);
    a.reset(motion.angle_rad(0));
    b.reset(motion.angle_rad(0));
    for (std::size_t i = 1; i < 5000; ++i) {
      const double ya = a.step(motion.angle_rad(i), motion.rate_radps(i), kDtS);
      const double yb = b.step(motion.angle_rad(i), motion.rate_radps(i), kDtS);
      if (!(std::abs(ya - yb) <= tol * (1.0 + std::abs(ya))) || b.bad_steps() != 0) {
        std::fprintf(stderr, "step/%s differs from %s/%s at step %zu: %.17g vs %.17g\n",
                     ib::model_kind_name(k), variant, ib::model_kind_name(k), i, yb, ya);
        return false;
      }
    }
  }
  return true;
}

// model/ is the model.hpp update itself (1e-12); update/ has no branch for small z, where
// phi1's series and the quotient differ in the last digits (1e-9).
bool check_step_matches_model() {
  return step_matches<ModelStepper<double>>("model", 1e-12) &&
         step_matches<UpdateStepper<double>>("update", 1e-9);
}

// --callgrind NAME N
template <class Scalar, class Stepper, class... Args>
int callgrind_run(std::size_t steps, Args... args) {
  auto stepper = std::make_unique<Stepper>(args...);
  const ib::Motion<Scalar> motion(1.0 / kDtS);
  std::vector<Scalar> angle(motion.size()), rate(motion.size());
  for (std::size_t i = 0; i < motion.size(); ++i) {
    angle[i] = motion.angle_rad(i);
    rate[i] = motion.rate_radps(i);
  }
  stepper->reset(angle[0]);
  Scalar prev = Scalar(0);
  std::size_t i = 1;
  const Scalar dt_s = Scalar(kDtS), chain = Scalar(kChainGain);
  for (std::size_t w = 0; w < 1000; ++w) {
    prev = stepper->step(angle[i] + chain * prev, rate[i], dt_s);
    if (++i == angle.size()) i = 0;
  }
  CALLGRIND_START_INSTRUMENTATION;
  for (std::size_t s = 0; s < steps; ++s) {
    prev = stepper->step(angle[i] + chain * prev, rate[i], dt_s);
    benchmark::DoNotOptimize(prev);
    if (++i == angle.size()) i = 0;
  }
  CALLGRIND_STOP_INSTRUMENTATION;
  std::printf("%.17g\n", static_cast<double>(prev));
  return 0;
}

int callgrind_main(const std::string& name, std::size_t steps) {
  std::vector<std::pair<std::string, std::function<int()>>> table;
  for (ModelKind k : {ModelKind::model_i, ModelKind::model_ii, ModelKind::two_lags}) {
    const std::string m = ib::model_kind_name(k);
    table.push_back({"step/" + m + "/double", [=] { return callgrind_run<double, PredictorStepper<double>>(steps, k); }});
    table.push_back({"step/" + m + "/float", [=] { return callgrind_run<float, PredictorStepper<float>>(steps, k); }});
    table.push_back({"state/" + m + "/double", [=] { return callgrind_run<double, StateStepper<double>>(steps, k); }});
    table.push_back({"c/" + m + "/double", [=] { return callgrind_run<double, CStepper>(steps, k); }});
    table.push_back({"model/" + m + "/double", [=] { return callgrind_run<double, ModelStepper<double>>(steps, k); }});
    table.push_back({"floor/" + m + "/double", [=] { return callgrind_run<double, FloorStepper<double>>(steps, k); }});
    table.push_back({"floor/" + m + "/float", [=] { return callgrind_run<float, FloorStepper<float>>(steps, k); }});
    table.push_back({"update/" + m + "/double", [=] { return callgrind_run<double, UpdateStepper<double>>(steps, k); }});
    table.push_back({"update/" + m + "/float", [=] { return callgrind_run<float, UpdateStepper<float>>(steps, k); }});
  }
  const ModelKind stall = ModelKind::model_ii_stall;
  table.push_back({"state/stall2/double", [=] {
                     return callgrind_run<double, StateStepper<double, indicial::FamilyState<double, Cap>>>(steps, stall);
                   }});
  table.push_back({"state/stall2/float", [=] {
                     return callgrind_run<float, StateStepper<float, indicial::FamilyState<float, Cap>>>(steps, stall);
                   }});
  table.push_back({"c/stall2/double", [=] { return callgrind_run<double, CStepper>(steps, stall); }});
  table.push_back({"state/stall2h/double", [=] {
                     return callgrind_run<double, StateStepper<double, indicial::FamilyState<double, Cap>>>(
                         steps, ModelKind::model_ii_stall_hysteresis);
                   }});
  for (const auto& [n, fn] : table)
    if (n == name) return fn();
  std::fprintf(stderr, "unknown variant %s\n", name.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 4 && std::strcmp(argv[1], "--callgrind") == 0)
    return callgrind_main(argv[2], std::strtoull(argv[3], nullptr, 10));
  if (!check_step_matches_model()) return 1;
  register_scalar<double>();
  register_scalar<float>();
  for (ModelKind k : {ModelKind::model_i, ModelKind::model_ii, ModelKind::two_lags})
    register_variant<double, CStepper>(std::string("c/") + ib::model_kind_name(k) + "/double", 1000, k);
  register_variant<double, Rk4Stepper<double>>("rk4/model2/double", 1000, ModelKind::model_ii);
  register_stall();
  register_variant<double, ConvolutionStepper<double>>("conv1s/model2/double", 3000,
                                                        ModelKind::model_ii, std::size_t{1000});
  register_variant<double, ConvolutionStepper<double>>("conv10s/model2/double", 30000,
                                                        ModelKind::model_ii, std::size_t{10000});
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
