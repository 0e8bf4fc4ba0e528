// fit_stepwise_output_error.cpp -- stepwise structure refinement on the output-error fit.
//
// Why: the equation-error regressors of a(x), x^i x' and (x - k)_+^2 x', are strongly
// collinear over a 0-70 deg oscillation, and the regression's dependent variable carries the
// noise of a smoothed derivative; from a large pool the greedy regression path then often
// takes a0 or a3 for a1 (docs/validation.md, "Stepwise regression"). The output-error fit has
// neither problem (no derivative of the data, the states integrate the forcing), so its
// likelihood is a better judge of which terms the data support. Starting from the regression's
// selection:
//   * entry: every pool term not in the model is tried by a full ML fit from the current
//     estimates (the new term at 0); the best by the partial F of the output error,
//     F = (SSE_0 - SSE_1) / (SSE_1 / (N - p_1)), enters if F > f_to_enter;
//   * removal: the term of the model with the smallest Wald F = (estimate / CR bound)^2
//     leaves if F < f_to_remove (an unidentifiable term leaves first), and the model is
//     refitted;
// until neither happens (each term moves -- enters or leaves -- at most four times, so it
// ends). Both F are t statistics squared of the term's estimate; with colored residuals
// (StepwiseSignificance::colored_residuals, the default) each is multiplied by
// var_white / var_colored of that estimate, the colored-residual (sandwich) bound of the fit
// holding the term, so F = estimate^2 / colored variance (fit_stepwise.cpp explains why); the
// log keeps the white F beside it. A trial fit the fitter refuses (InputError, e.g. more parameters than samples) is
// skipped, not fatal: the refinement only ever moves between fits that succeeded.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "estimate/fit_internal.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::fit_detail {
namespace {

bool refinable(const ParamId& t) {
  switch (t.kind) {
    case ParamKind::a_power:
    case ParamKind::a_knot:
    case ParamKind::con:
      return true;
    case ParamKind::b_power:
    case ParamKind::b_knot:
      return t.lag == 0;
    default:
      return false;
  }
}

// The refinable terms of s, as the POOL's ids (a structure numbers its own knots: the pool's
// A4 is A2 of a structure with two a(x) knots; the identity is the same, the name is the
// pool's).
std::vector<ParamId> pool_terms_of(const UnsteadyStructure& pool, const UnsteadyStructure& s) {
  const std::vector<ParamId> all = structural_terms(pool);
  std::vector<ParamId> out;
  for (const ParamId& t : structural_terms(s)) {
    if (!refinable(t)) continue;
    const auto it = std::find(all.begin(), all.end(), t);
    if (it != all.end()) out.push_back(*it);
  }
  return out;
}

// Whether `ids` hold an a(x) and a b1(x) term (a model needs one of each).
bool has_a_and_b1(const std::vector<ParamId>& ids) {
  bool a = false, b1 = false;
  for (const ParamId& t : ids) {
    a = a || t.kind == ParamKind::a_power || t.kind == ParamKind::a_knot;
    b1 = b1 || ((t.kind == ParamKind::b_power || t.kind == ParamKind::b_knot) && t.lag == 0);
  }
  return a && b1;
}

// The ML fit of the pool's sub-structure `ids`, started from `from` (by identity; new
// parameters at 0).
MLResult fit_terms(const UnsteadyStructure& pool, const std::vector<ParamId>& ids,
                   const OutputErrorData& d, const MLResult& from, const FitOptions& o) {
  const UnsteadyStructure s = select_terms(pool, ids);
  const ParameterLayout L(s, d.runs);
  Eigen::VectorXd theta0 = Eigen::VectorXd::Zero(L.size());
  for (std::size_t i = 0; i < from.ids.size(); ++i) {
    const int k = L.find(from.ids[i]);
    if (k >= 0) theta0(k) = from.theta(static_cast<Eigen::Index>(i));
  }
  return fit_output_error(s, d, theta0, o);
}

double sse(const MLResult& m) { return 2.0 * m.summary.cost; }

// var_white / var_colored of estimate i of m: 1 when the residuals are white (no significant
// lag), the white test is asked for, or a variance is not finite.
double colored_factor(const MLResult& m, std::size_t i, const FitOptions& o) {
  if (o.stepwise_significance == StepwiseSignificance::white_residuals || m.summary.correlation_lag == 0) return 1.0;
  const auto k = static_cast<Eigen::Index>(i);
  const double w = m.cov_white(k, k), c = m.cov_colored(k, k);
  return std::isfinite(w) && std::isfinite(c) && w > 0.0 && c > 0.0 ? w / c : 1.0;
}

struct Move {
  ParamId term;
  double f = 0.0;        // as judged
  double f_white = 0.0;  // white-residual F
  MLResult fit;
};

// The best entry: every pool term not in the model (and not moved 4 times) tried by a full
// ML fit; f = -inf when none could be fitted.
Move best_entry(const UnsteadyStructure& pool, const OutputErrorData& d, const MLResult& ml,
                const FitOptions& o, const std::map<ParamId, int>& moves) {
  const std::vector<ParamId> current = pool_terms_of(pool, ml.structure);
  const double n = static_cast<double>(ml.summary.n_samples);
  Move best;
  best.f = -std::numeric_limits<double>::infinity();
  for (const ParamId& c : pool_terms_of(pool, pool)) {
    const auto mv = moves.find(c);
    if (std::find(current.begin(), current.end(), c) != current.end() ||
        (mv != moves.end() && mv->second >= 4))
      continue;
    std::vector<ParamId> ids = current;
    ids.push_back(c);
    MLResult trial;
    try {
      trial = fit_terms(pool, ids, d, ml, o);
    } catch (const InputError&) {
      continue;
    }
    const double p1 = static_cast<double>(trial.theta.size());
    if (!std::isfinite(trial.summary.cost) || !(n > p1)) continue;
    const double f_white = (sse(ml) - sse(trial)) / (sse(trial) / (n - p1));
    const auto at = std::find(trial.ids.begin(), trial.ids.end(), c);
    const double f = at == trial.ids.end()
                         ? f_white
                         : f_white * colored_factor(trial, static_cast<std::size_t>(at - trial.ids.begin()), o);
    if (f > best.f) best = Move{c, f, f_white, std::move(trial)};
  }
  return best;
}

// The weakest term by its Wald F (an unidentifiable one first), among those whose removal
// leaves an a(x) and a b1(x) term; f = +inf when there is none.
Move weakest_term(const UnsteadyStructure& pool, const MLResult& ml, const FitOptions& o,
                  const std::map<ParamId, int>& moves) {
  const std::vector<ParamId> current = pool_terms_of(pool, ml.structure);
  Move worst;
  worst.f = std::numeric_limits<double>::infinity();
  for (const ParamId& term : current) {
    const auto mv = moves.find(term);
    if (mv != moves.end() && mv->second >= 4) continue;
    std::vector<ParamId> rest = current;
    rest.erase(std::find(rest.begin(), rest.end(), term));
    if (!has_a_and_b1(rest)) continue;
    const auto at = std::find(ml.ids.begin(), ml.ids.end(), term);
    if (at == ml.ids.end()) continue;
    const auto i = static_cast<std::size_t>(at - ml.ids.begin());
    const auto k = static_cast<Eigen::Index>(i);
    const double sd = std::sqrt(ml.cov_white(k, k));
    // Why 0 for an unidentifiable term: the data cannot tell it from the others, so it is
    // the first to go.
    const double f_white = (ml.identifiability[i] == Identifiability::identified && sd > 0.0)
                               ? (ml.theta(k) / sd) * (ml.theta(k) / sd)
                               : 0.0;
    const double f = f_white * colored_factor(ml, i, o);
    if (f < worst.f) {
      worst.term = term;
      worst.f = f;
      worst.f_white = f_white;
    }
  }
  return worst;
}

}  // namespace

std::vector<int> fallback_start_columns(const std::vector<ParamId>& terms) {
  // Why the lowest order: a constant a and b1 (or the first power / knot the pool offers) is
  // the simplest model with one lag; the output-error stepwise adds what the data support.
  int a = -1, b1 = -1;
  auto lower = [&](int current, std::size_t j) {
    if (current < 0) return true;
    const ParamId& x = terms[j];
    const ParamId& y = terms[static_cast<std::size_t>(current)];
    const bool x_power = x.kind == ParamKind::a_power || x.kind == ParamKind::b_power;
    const bool y_power = y.kind == ParamKind::a_power || y.kind == ParamKind::b_power;
    if (x_power != y_power) return x_power;  // a power before any knot
    return x_power ? x.power < y.power : x.knot_rad < y.knot_rad;
  };
  for (std::size_t j = 0; j < terms.size(); ++j) {
    const ParamId& t = terms[j];
    if ((t.kind == ParamKind::a_power || t.kind == ParamKind::a_knot) && lower(a, j)) a = static_cast<int>(j);
    const bool is_b1 = (t.kind == ParamKind::b_power || t.kind == ParamKind::b_knot) && t.lag == 0;
    if (is_b1 && lower(b1, j)) b1 = static_cast<int>(j);
  }
  if (a < 0 || b1 < 0) return {};
  return a < b1 ? std::vector<int>{a, b1} : std::vector<int>{b1, a};
}

MLResult refine_structure_output_error(const UnsteadyStructure& pool, const OutputErrorData& d,
                                       MLResult ml, const FitOptions& o,
                                       OutputErrorStepwiseResult* log) {
  const std::size_t n_pool = pool_terms_of(pool, pool).size();
  std::map<ParamId, int> moves;  // entries + removals per term: at most 4 each
  for (int round = 0; round < 4 * static_cast<int>(n_pool) + 4; ++round) {
    bool changed = false;
    Move in = best_entry(pool, d, ml, o, moves);
    if (in.f > o.f_to_enter) {  // -inf when no trial fit succeeded
      log->steps.push_back({OutputErrorStepwiseStep::Action::entered, parameter_name(in.term),
                            in.f, in.f_white, sse(ml), sse(in.fit)});
      ++moves[in.term];
      ml = std::move(in.fit);
      changed = true;
    }
    const Move out = weakest_term(pool, ml, o, moves);
    if (out.f < o.f_to_remove) {  // +inf when no term may leave
      std::vector<ParamId> rest = pool_terms_of(pool, ml.structure);
      rest.erase(std::find(rest.begin(), rest.end(), out.term));
      MLResult refit;
      bool fitted = true;
      try {
        refit = fit_terms(pool, rest, d, ml, o);
      } catch (const InputError&) {
        fitted = false;
      }
      if (fitted && std::isfinite(refit.summary.cost)) {
        log->steps.push_back({OutputErrorStepwiseStep::Action::removed, parameter_name(out.term),
                              out.f, out.f_white, sse(ml), sse(refit)});
        ++moves[out.term];
        ml = std::move(refit);
        changed = true;
      }
    }
    if (!changed) break;
  }
  for (const ParamId& t : pool_terms_of(pool, ml.structure)) log->selected.push_back(parameter_name(t));
  return ml;
}

}  // namespace indicial::fit_detail
