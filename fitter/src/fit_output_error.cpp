// fit_output_error.cpp -- maximum-likelihood output error (report eqs. 23-24).
//
// The state is propagated from the measured model angle, sample to sample, with
// indicial::advance_lags -- the runtime's own discrete update -- and the residual is
// v = y_E - y_model. For white Gaussian noise of unknown variance the ML estimate minimises
// J = 0.5 sum v^2; s(v)^2 = sum v^2 / N. The Gauss-Newton / Levenberg-Marquardt iteration uses
// EXACT sensitivities: the same template is evaluated with Eigen's forward AutoDiffScalar
// (fixed-size derivative vectors, so no heap per operation). No finite differences.
//
// Parameters: the structural coefficients (a, A, b1, B, con, further lags) and, for every
// non-periodic run, its initial state(s) y0. A periodic run's state is the periodic steady
// state: with y(end) = Phi y0 + psi per lag (the update is affine in y for a given model),
// propagating from y0 = 0 gives psi, from y0 = 1 gives Phi + psi, and y0 = psi / (1 - Phi);
// done with the autodiff type, its sensitivities come for free.
//
// Convergence (documented in fit.hpp): an accepted step with relative cost change below
// cost_tolerance AND every parameter change below step_tolerance times its Cramer-Rao bound.
// A rejected step whose undamped size is already below step_tolerance bounds also counts as
// converged (the cost cannot decrease further within round-off).
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/AutoDiff>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "fit_internal.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::fit_detail {

namespace {

constexpr int kMaxDerivatives = 64;

template <class S>
void fill_spline(const SplineTerms& t, const S* coef, Spline<S, Cap::max_powers, Cap::max_knots>& s) {
  int n_powers = 0;
  for (int p : t.powers) n_powers = std::max(n_powers, p + 1);
  s.n_powers = n_powers;
  for (int i = 0; i < Cap::max_powers; ++i) s.power_coef[i] = S(0);
  for (std::size_t i = 0; i < t.powers.size(); ++i) s.power_coef[t.powers[i]] = coef[i];
  s.n_knots = static_cast<int>(t.knots_rad.size());
  for (std::size_t j = 0; j < t.knots_rad.size(); ++j) {
    s.knot_rad[j] = t.knots_rad[j];
    s.knot_power[j] = t.knot_power;
    s.knot_coef[j] = coef[t.powers.size() + j];
  }
}

template <class S>
void build_model(const UnsteadyStructure& s, const S* th, CoefficientModel<S, Cap>& m) {
  const S* p = th;
  fill_spline(s.a, p, m.a);
  p += s.a.size();
  m.n_lags = s.lags;
  fill_spline(s.b1, p, m.lags[0].b);
  p += s.b1.size();
  m.lags[0].gain = S(1);
  m.con = S(0);
  if (s.con == Bias::present) m.con = *p++;
  for (std::size_t k = 0; k < s.b_more.size(); ++k) {
    fill_spline(s.b_more[k], p, m.lags[k + 1].b);
    p += s.b_more[k].size();
    m.lags[k + 1].gain = *p++;
  }
  m.delay_s = S(0);
  if (s.delay == DelayTerm::estimated) m.delay_s = *p++;
}

void check_capacity(const UnsteadyStructure& s, const std::string& file) {
  auto check = [&](const SplineTerms& t, const char* what) {
    int n_powers = 0;
    for (int p : t.powers) n_powers = std::max(n_powers, p + 1);
    if (n_powers > Cap::max_powers || static_cast<int>(t.knots_rad.size()) > Cap::max_knots)
      throw InputError(file, 0, fmt::format("{} needs powers up to x^{} and {} knots; the fitter "
                                            "holds at most x^{} and {} knots", what, n_powers - 1,
                                            t.knots_rad.size(), Cap::max_powers - 1, Cap::max_knots));
  };
  check(s.a, "a(x)");
  check(s.b1, "b1(x)");
  for (const auto& b : s.b_more) check(b, "a further lag's b(x)");
  check(s.rotary, "C_aq(x)");
  check(s.static_corr, "the static correction dC_a(x)");
  if (s.lags > Cap::max_lags)
    throw InputError(file, 0, fmt::format("{} lags; at most {}", s.lags, Cap::max_lags));
}

// The forcing angles x_f(t_k) of a run: x itself without a delay; with an estimated delay,
// x(t_k - delay) through the shared indicial::delayed_angle (linear interpolation in time over
// the run's samples, the first sample's angle before them), whose derivative with respect to
// the delay an autodiff S carries into the sensitivities.
template <class S>
struct Forcing {
  const PreparedRun& r;
  const S* delay = nullptr;  // null: no delay
  ArrayHistory<double> h{};
  Forcing(const PreparedRun& run, const CoefficientModel<S, Cap>& m, DelayTerm d) : r(run) {
    if (d == DelayTerm::estimated) {
      delay = &m.delay_s;
      h = ArrayHistory<double>{run.t.data(), run.x.data(), static_cast<int>(run.x.size())};
    }
  }
  S at(std::size_t k) const {
    // Why the branch: without a delay the forcing angle is the sample itself (no search).
    if (!delay) return S(r.x[k]);
    return delayed_angle(h, r.t[k], *delay);
  }
  // The spline ends at sample k. Why the branch: without a delay both angles are data, passed
  // as plain doubles so that an autodiff S does no derivative work on them (same values, see
  // indicial::spline_antiderivative).
  void ends_at(const CoefficientModel<S, Cap>& m, std::size_t k, StepEnd<S, Cap>* end) const {
    if (!delay) evaluate_step_end(m, r.x[k], r.x[k], end);
    else evaluate_step_end(m, r.x[k], at(k), end);
  }
};

// Whether the run's last sample repeats the first (a closed cycle) -- then the cycle closes at
// the last sample; otherwise one more step of dt from the last sample back to the first.
bool closes_on_last_sample(const PreparedRun& r) {
  return std::abs(r.x.back() - r.x.front()) <= 1e-9;
}

// Periodic steady state of every lag; false when some lag has no periodic solution
// (Phi >= 1: the time constant is not positive on average over the cycle).
template <class S>
bool periodic_state(const CoefficientModel<S, Cap>& m, const PreparedRun& r, DelayTerm d, S* y0) {
  const Forcing<S> f(r, m, d);
  S ya[Cap::max_lags], yb[Cap::max_lags];
  for (int j = 0; j < m.n_lags; ++j) {
    ya[j] = S(0);
    yb[j] = S(1);
  }
  const std::size_t n = r.x.size();
  const bool closed = closes_on_last_sample(r);
  const std::size_t steps = closed ? n - 1 : n;
  // The spline ends of a step are those of the next step's start: evaluated once per sample
  // and shared by both propagations (what advance_lags would compute, bit for bit).
  StepEnd<S, Cap> end0, end1;
  f.ends_at(m, 0, &end0);
  for (std::size_t k = 0; k < steps; ++k) {
    const std::size_t k1 = (k + 1 == n) ? 0 : k + 1;
    // With a delay the cycle's start uses the first sample's angle before it (delayed_angle's
    // rule), not the previous cycle's end: a small approximation for periodic runs.
    const StepGeometry<S> g{S(r.x[k]), S(r.x[k1]), f.at(k), f.at(k1), S(r.dt_s), S(1)};
    f.ends_at(m, k1, &end1);
    advance_lags_between(m, g, end0, end1, ya);
    advance_lags_between(m, g, end0, end1, yb);
    end0 = end1;
  }
  for (int j = 0; j < m.n_lags; ++j) {
    const S phi = yb[j] - ya[j];
    // Why: 1 - Phi <= 0 means the homogeneous solution does not decay over a cycle, so no
    // periodic steady state exists (and the division would blow up or flip sign).
    if (!(phi < S(1 - 1e-12))) return false;
    y0[j] = ya[j] / (S(1) - phi);
  }
  return true;
}

// Propagates run r from state y (in/out, n_lags values) and calls emit(i, y_sum) per sample.
template <class S, class Emit>
void propagate(const CoefficientModel<S, Cap>& m, const PreparedRun& r, DelayTerm d, S* y,
               Emit&& emit) {
  const Forcing<S> f(r, m, d);
  S xf0 = f.at(0);
  auto sum = [&]() {
    S s = y[0];
    for (int j = 1; j < m.n_lags; ++j) s = s + y[j];
    return s;
  };
  emit(std::size_t{0}, sum());
  // As the runtime does: each sample's spline ends are evaluated once and serve as the end of
  // one step and the start of the next (bit-identical to advance_lags, half the spline work,
  // which dominates the sensitivities' cost).
  StepEnd<S, Cap> end0, end1;
  f.ends_at(m, 0, &end0);
  for (std::size_t k = 0; k + 1 < r.x.size(); ++k) {
    const S xf1 = f.at(k + 1);
    const StepGeometry<S> g{S(r.x[k]), S(r.x[k + 1]), xf0, xf1, S(r.dt_s), S(1)};
    f.ends_at(m, k + 1, &end1);
    advance_lags_between(m, g, end0, end1, y);
    end0 = end1;
    xf0 = xf1;
    emit(k + 1, sum());
  }
}

struct Layout {
  int n_struct = 0;
  int n_rotary = 0;  // rotary coefficients, after the structural ones
  int n_static = 0;  // static correction coefficients, after the rotary ones
  bool replaces_rotary = false;
  int lags = 1;
  int y0_per_run = 1;  // lags, or 1 when the further lags start at rest
  std::vector<int> y0_offset;  // per run: index of its first y0 parameter, -1 if periodic
  int n_params = 0;
  std::size_t n_samples = 0;
  std::vector<std::size_t> starts;
};

Layout make_layout(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs) {
  Layout L;
  L.n_struct = s.n_struct();
  L.n_rotary = static_cast<int>(s.rotary.size());
  L.n_static = static_cast<int>(s.static_corr.size());
  L.replaces_rotary = L.n_rotary > 0 && s.rotary_role == RotaryRole::replaces_a_priori;
  L.lags = s.lags;
  L.y0_per_run = s.y0_per_run();
  int next = L.n_struct + L.n_rotary + L.n_static;
  L.starts.push_back(0);
  for (const PreparedRun& r : runs) {
    if (r.periodic) {
      L.y0_offset.push_back(-1);
    } else {
      L.y0_offset.push_back(next);
      next += L.y0_per_run;
    }
    L.n_samples += r.x.size();
    L.starts.push_back(L.n_samples);
  }
  L.n_params = next;
  return L;
}

// The measured side and the rotary part of the model at sample i: with jointly estimated
// rotary terms the target is C - C_a(x) and the model adds (l/V) C_aq(x) rate; otherwise the
// target is y_E (eq. 12) and the rotary part is already in it.
// Diagnose's correcting rotary terms and static-correction terms add to y_E's model likewise.
double target(const PreparedRun& r, std::size_t i, const Layout& L) {
  return L.replaces_rotary ? r.coef[i] - r.static_value[i] : r.y_e[i];
}
double rotary_part(const UnsteadyStructure& s, const Layout& L, const Eigen::VectorXd& theta,
                   const PreparedRun& r, std::size_t i) {
  double c = 0.0;
  for (int k = 0; k < L.n_rotary; ++k)
    c += theta(L.n_struct + k) * rotary_basis(s.rotary, static_cast<std::size_t>(k), r.x[i]);
  double d = 0.0;
  for (int k = 0; k < L.n_static; ++k)
    d += theta(L.n_struct + L.n_rotary + k) *
         rotary_basis(s.static_corr, static_cast<std::size_t>(k), r.x[i]);
  return s.l_over_v_s * c * r.rate[i] + d;
}

// Residuals at theta (double). Returns false if the model cannot be propagated (no periodic
// state) or produces non-finite values.
bool residuals(const UnsteadyStructure& s, const Layout& L, const std::vector<PreparedRun>& runs,
               const Eigen::VectorXd& theta, Eigen::VectorXd& v,
               std::vector<std::vector<double>>* y_model) {
  CoefficientModel<double, Cap> m;
  build_model(s, theta.data(), m);
  v.resize(static_cast<Eigen::Index>(L.n_samples));
  if (y_model) y_model->assign(runs.size(), {});
  for (std::size_t ri = 0; ri < runs.size(); ++ri) {
    const PreparedRun& r = runs[ri];
    double y[Cap::max_lags] = {};
    if (L.y0_offset[ri] < 0) {
      if (!periodic_state(m, r, s.delay, y)) return false;
    } else {
      for (int j = 0; j < L.y0_per_run; ++j) y[j] = theta(L.y0_offset[ri] + j);
    }
    const auto base = static_cast<Eigen::Index>(L.starts[ri]);
    if (y_model) (*y_model)[ri].resize(r.x.size());
    propagate(m, r, s.delay, y, [&](std::size_t i, double ys) {
      v(base + static_cast<Eigen::Index>(i)) = target(r, i, L) - ys - rotary_part(s, L, theta, r, i);
      if (y_model) (*y_model)[ri][i] = ys;
    });
  }
  return v.allFinite();
}

// Residuals and Jacobian dv/dtheta with forward autodiff. Per run the derivative vector holds
// the structural parameters and that run's own y0 (n_struct + lags entries), mapped into the
// global columns afterwards, so the derivative size does not grow with the number of runs.
//
// Why fixed-size derivative vectors (N = 8, 16 or 64, the smallest that holds n_struct + lags)
// rather than Eigen::Dynamic with a maximum: with dynamic derivatives a constant such as the
// first lag's gain Scalar(1) carries an EMPTY derivative vector, and Eigen's AutoDiff only makes
// sizes coherent when a plain (non-expression) operand is the empty one; an expression such as
// -gain * forcing_integral then combines vectors of different sizes, which asserts in debug
// builds and silently yields wrong sensitivities under NDEBUG. A fixed-size vector is
// zero-filled for every constant, so any expression the shared model writes is exact.
template <int N>
bool jacobian_n(const UnsteadyStructure& s, const Layout& L, const std::vector<PreparedRun>& runs,
                const Eigen::VectorXd& theta, Eigen::VectorXd& v, Eigen::MatrixXd& J) {
  using ADN = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;
  auto seeded = [](double value, int index) {
    ADN a(value);
    a.derivatives().setZero();
    a.derivatives()(index) = 1.0;
    return a;
  };
  std::vector<ADN> th(static_cast<std::size_t>(L.n_struct));
  for (int i = 0; i < L.n_struct; ++i) th[static_cast<std::size_t>(i)] = seeded(theta(i), i);
  CoefficientModel<ADN, Cap> m;
  build_model(s, th.data(), m);
  v.resize(static_cast<Eigen::Index>(L.n_samples));
  J.setZero(static_cast<Eigen::Index>(L.n_samples), L.n_params);
  for (std::size_t ri = 0; ri < runs.size(); ++ri) {
    const PreparedRun& r = runs[ri];
    ADN y[Cap::max_lags];
    for (int j = 0; j < Cap::max_lags; ++j) y[j] = ADN(0.0);
    if (L.y0_offset[ri] < 0) {
      if (!periodic_state(m, r, s.delay, y)) return false;
    } else {
      for (int j = 0; j < L.y0_per_run; ++j) y[j] = seeded(theta(L.y0_offset[ri] + j), L.n_struct + j);
    }
    const auto base = static_cast<Eigen::Index>(L.starts[ri]);
    const int off = L.y0_offset[ri];
    propagate(m, r, s.delay, y, [&](std::size_t i, const ADN& ys) {
      const Eigen::Index row = base + static_cast<Eigen::Index>(i);
      v(row) = target(r, i, L) - ys.value() - rotary_part(s, L, theta, r, i);
      const auto& d = ys.derivatives();
      for (int k = 0; k < L.n_struct; ++k) J(row, k) = -d(k);
      // The rotary part is linear in its coefficients: exact sensitivities without autodiff.
      for (int k = 0; k < L.n_rotary; ++k)
        J(row, L.n_struct + k) = -s.l_over_v_s *
                                 rotary_basis(s.rotary, static_cast<std::size_t>(k), r.x[i]) *
                                 r.rate[i];
      for (int k = 0; k < L.n_static; ++k)
        J(row, L.n_struct + L.n_rotary + k) =
            -rotary_basis(s.static_corr, static_cast<std::size_t>(k), r.x[i]);
      if (off >= 0)
        for (int j = 0; j < L.y0_per_run; ++j) J(row, off + j) = -d(L.n_struct + j);
    });
  }
  return v.allFinite() && J.allFinite();
}

bool jacobian(const UnsteadyStructure& s, const Layout& L, const std::vector<PreparedRun>& runs,
              const Eigen::VectorXd& theta, Eigen::VectorXd& v, Eigen::MatrixXd& J) {
  const int nd = L.n_struct + L.lags;
  if (nd <= 8) return jacobian_n<8>(s, L, runs, theta, v, J);
  if (nd <= 16) return jacobian_n<16>(s, L, runs, theta, v, J);
  return jacobian_n<kMaxDerivatives>(s, L, runs, theta, v, J);
}

// Information-matrix analysis on unit-diagonal scaling: pseudo-inverse of A = J'J restricted to
// its numerical range, the rank, and which parameters touch the null space.
struct InfoAnalysis {
  Eigen::MatrixXd pinv;
  int rank = 0;
  std::vector<bool> in_null_space;
};

InfoAnalysis analyse_information(const Eigen::MatrixXd& A, double sv_cutoff) {
  const Eigen::Index p = A.rows();
  InfoAnalysis r;
  r.in_null_space.assign(static_cast<std::size_t>(p), false);
  Eigen::VectorXd d = A.diagonal().cwiseMax(0.0).cwiseSqrt();
  Eigen::VectorXd dinv(p);
  for (Eigen::Index i = 0; i < p; ++i) dinv(i) = d(i) > 0.0 ? 1.0 / d(i) : 0.0;
  Eigen::MatrixXd As = dinv.asDiagonal() * A * dinv.asDiagonal();
  // Why: a parameter whose column of J is exactly zero has no information at all; give it a
  // unit diagonal so the eigen-analysis puts it (alone) in the null space.
  for (Eigen::Index i = 0; i < p; ++i)
    if (d(i) == 0.0) As(i, i) = 0.0;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(As);
  const Eigen::VectorXd& ev = es.eigenvalues();  // ascending
  const double emax = ev(p - 1);
  // Cut-off on singular values of the scaled J = sqrt(eigenvalues of the scaled A).
  const double cut = sv_cutoff * sv_cutoff * emax;
  Eigen::MatrixXd pin = Eigen::MatrixXd::Zero(p, p);
  for (Eigen::Index k = 0; k < p; ++k) {
    const Eigen::VectorXd vk = es.eigenvectors().col(k);
    if (ev(k) > cut && emax > 0.0) {
      pin += vk * vk.transpose() / ev(k);
      ++r.rank;
    } else {
      for (Eigen::Index i = 0; i < p; ++i)
        if (vk(i) * vk(i) > 0.01) r.in_null_space[static_cast<std::size_t>(i)] = true;
    }
  }
  for (Eigen::Index i = 0; i < p; ++i)
    if (d(i) == 0.0) r.in_null_space[static_cast<std::size_t>(i)] = true;
  r.pinv = dinv.asDiagonal() * pin * dinv.asDiagonal();
  return r;
}

}  // namespace

double rotary_basis(const SplineTerms& rotary, std::size_t k, double x) {
  if (k < rotary.powers.size()) return std::pow(x, rotary.powers[k]);
  const double u = x - rotary.knots_rad[k - rotary.powers.size()];
  if (!(u > 0.0)) return 0.0;
  double r = 1.0;
  for (int i = 0; i < rotary.knot_power; ++i) r *= u;
  return r;
}

int n_initial_states(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs) {
  int n = 0;
  for (const PreparedRun& r : runs)
    if (!r.periodic) n += s.y0_per_run();
  return n;
}

std::vector<std::string> parameter_names(const UnsteadyStructure& s,
                                         const std::vector<PreparedRun>& runs) {
  std::vector<std::string> names;
  for (const Term& t : structural_terms(s)) names.push_back(t.name);
  for (const Term& t : rotary_terms(s.rotary)) names.push_back(t.name);
  for (const Term& t : static_corr_terms(s.static_corr)) names.push_back(t.name);
  for (std::size_t r = 0; r < runs.size(); ++r) {
    if (runs[r].periodic) continue;
    names.push_back("y0_" + std::to_string(r + 1));
    for (int j = 1; j < s.y0_per_run(); ++j)
      names.push_back("y0_" + std::to_string(r + 1) + "_" + std::to_string(j + 1));
  }
  return names;
}

void set_unsteady(const UnsteadyStructure& s, const double* theta, CoefficientModel<double, Cap>& m) {
  build_model(s, theta, m);
}

namespace {
// Adds coef * basis term into a double spline: powers into power_coef (n_powers grown), knots
// merged with an existing knot of the same position and power or appended.
void add_term(SplineD& sp, const Term& t, double coef, const char* what) {
  const bool power = t.kind == TermKind::rotary_power || t.kind == TermKind::static_power;
  if (power) {
    if (t.power >= Cap::max_powers) throw std::logic_error(std::string(what) + ": power too high");
    for (int i = sp.n_powers; i <= t.power; ++i) sp.power_coef[i] = 0.0;
    sp.n_powers = std::max(sp.n_powers, t.power + 1);
    sp.power_coef[t.power] += coef;
    return;
  }
  for (int j = 0; j < sp.n_knots; ++j)
    if (sp.knot_rad[j] == t.knot_rad && sp.knot_power[j] == t.power) {
      sp.knot_coef[j] += coef;
      return;
    }
  if (sp.n_knots >= Cap::max_knots) throw std::logic_error(std::string(what) + ": too many knots");
  sp.knot_rad[sp.n_knots] = t.knot_rad;
  sp.knot_power[sp.n_knots] = t.power;
  sp.knot_coef[sp.n_knots] = coef;
  ++sp.n_knots;
}
}  // namespace

void add_output_terms(const UnsteadyStructure& s, const double* theta,
                      CoefficientModel<double, Cap>& m) {
  const int ns = s.n_struct();
  const std::vector<Term> rt = rotary_terms(s.rotary);
  if (!rt.empty() && s.rotary_role == RotaryRole::replaces_a_priori) m.rotary = SplineD{};
  for (std::size_t k = 0; k < rt.size(); ++k)
    add_term(m.rotary, rt[k], theta[static_cast<std::size_t>(ns) + k], "C_aq(x)");
  const std::vector<Term> st = static_corr_terms(s.static_corr);
  for (std::size_t k = 0; k < st.size(); ++k)
    add_term(m.static_correction, st[k], theta[static_cast<std::size_t>(ns) + rt.size() + k],
             "dC_a(x)");
}

MLResult fit_output_error(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs,
                          const Eigen::VectorXd& theta0, const FitOptions& o,
                          const std::string& context_file) {
  check_capacity(s, context_file);
  const Layout L = make_layout(s, runs);
  if (L.n_struct + L.lags > kMaxDerivatives)
    throw InputError(context_file, 0, fmt::format("{} model parameters; the output-error fitter "
                                                  "handles at most {}", L.n_struct,
                                                  kMaxDerivatives - L.lags));
  if (theta0.size() != L.n_params)
    throw std::logic_error("fit_output_error: start vector has the wrong size");
  if (static_cast<std::size_t>(L.n_params) >= L.n_samples)
    throw InputError(context_file, 0,
                     fmt::format("{} samples for {} output-error parameters: need more samples "
                                 "than parameters", L.n_samples, L.n_params));
  MLResult res;
  res.structure = s;
  res.names = parameter_names(s, runs);
  OutputErrorSummary& sum = res.summary;
  sum.n_samples = L.n_samples;
  sum.n_parameters = L.n_params;
  const double N = static_cast<double>(L.n_samples);

  Eigen::VectorXd theta = theta0, v, J_v;
  Eigen::MatrixXd J;
  double cost = std::numeric_limits<double>::infinity();
  if (residuals(s, L, runs, theta, v, nullptr)) cost = 0.5 * v.squaredNorm();
  bool finished = false;
  if (!std::isfinite(cost)) {
    sum.termination = Termination::diverged;
    sum.message = "the start values give a model that cannot be propagated (non-finite output "
                  "or no periodic steady state); nothing estimated";
    finished = true;
  }
  double lambda = 1e-3;
  int iter = 0;
  bool have_jacobian = false;
  while (!finished) {
    if (iter >= o.max_iterations) {
      sum.termination = Termination::iteration_limit;
      sum.message = fmt::format("iteration limit ({}) reached before convergence; best "
                                "estimate kept", o.max_iterations);
      break;
    }
    ++iter;
    if (!jacobian(s, L, runs, theta, v, J)) {
      sum.termination = Termination::diverged;
      sum.message = "sensitivities became non-finite; best estimate kept";
      break;
    }
    have_jacobian = true;
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * v;
    const InfoAnalysis info = analyse_information(A, o.sv_cutoff);
    const double s2 = 2.0 * cost / N;
    Eigen::VectorXd bound(L.n_params);
    for (Eigen::Index i = 0; i < L.n_params; ++i) bound(i) = std::sqrt(std::max(0.0, s2 * info.pinv(i, i)));
    Eigen::VectorXd diag = A.diagonal();
    const double dmax = diag.maxCoeff();
    // Why the floor: a zero column (unidentifiable parameter) would make the damped matrix
    // singular; a tiny floor keeps the solve defined and the step in that direction ~0.
    for (Eigen::Index i = 0; i < diag.size(); ++i) diag(i) = std::max(diag(i), 1e-12 * dmax + 1e-300);
    bool accepted = false;
    bool first_trial = true;
    while (true) {
      Eigen::MatrixXd Ad = A;
      Ad.diagonal() += lambda * diag;
      const Eigen::VectorXd delta = Ad.ldlt().solve(-g);
      double step_in_bounds = 0.0;
      for (Eigen::Index i = 0; i < L.n_params; ++i)
        if (!info.in_null_space[static_cast<std::size_t>(i)] && bound(i) > 0.0)
          step_in_bounds = std::max(step_in_bounds, std::abs(delta(i)) / bound(i));
      const Eigen::VectorXd trial = theta + delta;
      Eigen::VectorXd vt;
      double ct = std::numeric_limits<double>::infinity();
      if (delta.allFinite() && residuals(s, L, runs, trial, vt, nullptr)) ct = 0.5 * vt.squaredNorm();
      if (ct < cost) {
        const double rel = (cost - ct) / cost;
        theta = trial;
        cost = ct;
        sum.log.push_back({iter, cost, lambda, step_in_bounds});
        lambda = std::max(lambda * 0.1, 1e-10);
        accepted = true;
        if (rel < o.cost_tolerance && step_in_bounds < o.step_tolerance) {
          sum.termination = Termination::converged;
          finished = true;
        }
        break;
      }
      // Why: when even the least-damped step is already negligible against the bounds, the
      // cost cannot go lower within round-off: we are at the minimum.
      if (first_trial && step_in_bounds < o.step_tolerance) {
        sum.termination = Termination::converged;
        finished = true;
        break;
      }
      first_trial = false;
      lambda *= 10.0;
      if (lambda > o.max_damping) {
        sum.termination = Termination::diverged;
        sum.message = "no damped Gauss-Newton step lowered the cost (damping above its limit); "
                      "best estimate kept";
        finished = true;
        break;
      }
    }
    (void)accepted;
  }
  sum.iterations = iter;
  res.theta = theta;
  sum.cost = cost;
  const Eigen::Index P = L.n_params;
  res.cov_white = Eigen::MatrixXd::Constant(P, P, std::numeric_limits<double>::quiet_NaN());
  res.cov_colored = res.cov_white;
  res.identifiability.assign(static_cast<std::size_t>(P), Identifiability::identified);
  if (!std::isfinite(cost)) {
    sum.fit_error = std::numeric_limits<double>::quiet_NaN();
    for (auto& id : res.identifiability) id = Identifiability::not_identifiable;
    return res;
  }
  // Final sensitivities at the estimate (the loop's last Jacobian is at the previous point
  // when the last step was accepted).
  (void)have_jacobian;
  if (!jacobian(s, L, runs, theta, v, J)) {
    sum.termination = Termination::diverged;
    sum.message = "sensitivities are non-finite at the estimate";
    return res;
  }
  residuals(s, L, runs, theta, v, &res.y_model);
  const double s2 = v.squaredNorm() / N;
  sum.fit_error = std::sqrt(s2);
  const Eigen::MatrixXd A = J.transpose() * J;
  const InfoAnalysis info = analyse_information(A, o.sv_cutoff);
  sum.rank = info.rank;
  // Cramer-Rao: M = J'J / s^2, bounds sqrt(diag(M^-1)).
  Eigen::MatrixXd cw = s2 * info.pinv;
  sum.correlation_lag = choose_correlation_lag(v, L.starts, o);
  Eigen::MatrixXd cc = info.pinv * colored_middle(J, v, L.starts, sum.correlation_lag) * info.pinv;
  for (Eigen::Index i = 0; i < P; ++i) {
    if (!info.in_null_space[static_cast<std::size_t>(i)]) continue;
    res.identifiability[static_cast<std::size_t>(i)] = Identifiability::not_identifiable;
    sum.unidentifiable.push_back(res.names[static_cast<std::size_t>(i)]);
    // Why NaN: a null-space direction has no finite variance; printing the pseudo-inverse's
    // number (or a huge one) would pretend to an accuracy that does not exist.
    cw.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
    cw.col(i).setConstant(std::numeric_limits<double>::quiet_NaN());
    cc.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
    cc.col(i).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  res.cov_white = cw;
  res.cov_colored = cc;
  if (!sum.unidentifiable.empty()) {
    std::string list;
    for (const auto& n : sum.unidentifiable) list += (list.empty() ? "" : ", ") + n;
    sum.message = fmt::format("information matrix is rank deficient (rank {} of {}); not "
                              "identifiable: {}{}", info.rank, P, list,
                              sum.message.empty() ? "" : "; " + sum.message);
    sum.termination = Termination::rank_deficient;
  } else if (sum.termination == Termination::converged) {
    sum.message = fmt::format("converged in {} iterations, s(v) = {:.4g}", iter, sum.fit_error);
  }
  return res;
}

}  // namespace indicial::fit_detail
