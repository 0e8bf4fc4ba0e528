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
// ends). A trial fit the fitter refuses (InputError, e.g. more parameters than samples) is
// skipped, not fatal: the refinement only ever moves between fits that succeeded.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "fit_internal.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::fit_detail {
namespace {

bool refinable(TermKind k, int lag) {
  switch (k) {
    case TermKind::a_power:
    case TermKind::a_knot:
    case TermKind::con:
      return true;
    case TermKind::b_power:
    case TermKind::b_knot:
      return lag == 0;
    default:
      return false;
  }
}

// The refinable terms of s by their POOL names (a structure numbers its own knots: the pool's
// A4 is A2 of a structure with two a(x) knots), paired with their names in s.
struct Named { std::string pool; std::string own; };
std::vector<Named> refinable_terms(const UnsteadyStructure& pool, const UnsteadyStructure& s) {
  const std::vector<Term> pool_terms = structural_terms(pool);
  std::vector<Named> out;
  for (const Term& t : structural_terms(s)) {
    if (!refinable(t.kind, t.lag)) continue;
    for (const Term& p : pool_terms) {
      const bool knot = t.kind == TermKind::a_knot || t.kind == TermKind::b_knot;
      if (p.kind == t.kind && p.lag == t.lag &&
          (knot ? p.knot_rad == t.knot_rad : p.power == t.power)) {
        out.push_back({p.name, t.name});
        break;
      }
    }
  }
  return out;
}

std::vector<std::string> pool_names_of(const UnsteadyStructure& pool, const UnsteadyStructure& s) {
  std::vector<std::string> out;
  for (const Named& n : refinable_terms(pool, s)) out.push_back(n.pool);
  return out;
}

// Counts of a(x) and b1(x) terms among `names` (a model needs one of each).
struct Counts { int a = 0, b1 = 0; };
Counts counts(const UnsteadyStructure& pool, const std::vector<std::string>& names) {
  Counts c;
  for (const Term& t : structural_terms(pool)) {
    if (std::find(names.begin(), names.end(), t.name) == names.end()) continue;
    if (t.kind == TermKind::a_power || t.kind == TermKind::a_knot) ++c.a;
    if ((t.kind == TermKind::b_power || t.kind == TermKind::b_knot) && t.lag == 0) ++c.b1;
  }
  return c;
}

// The ML fit of the pool's sub-structure `names`, started from `from` (by parameter name;
// new parameters at 0).
MLResult fit_names(const UnsteadyStructure& pool, const std::vector<std::string>& names,
                   const std::vector<PreparedRun>& runs, const MLResult& from, const FitOptions& o,
                   const std::string& file) {
  const UnsteadyStructure s = select_terms(pool, names);
  // Start values by pool identity for the refinable terms (their own names are renumbered),
  // by name for the rest (y0_*).
  std::map<std::string, std::string> from_own_to_pool, new_own_to_pool;
  for (const Named& n : refinable_terms(pool, from.structure)) from_own_to_pool[n.own] = n.pool;
  for (const Named& n : refinable_terms(pool, s)) new_own_to_pool[n.own] = n.pool;
  std::map<std::string, double> value_of;  // keyed by pool name or own name
  for (std::size_t i = 0; i < from.names.size(); ++i) {
    const auto it = from_own_to_pool.find(from.names[i]);
    value_of[it != from_own_to_pool.end() ? it->second : from.names[i]] =
        from.theta(static_cast<Eigen::Index>(i));
  }
  const std::vector<std::string> pn = parameter_names(s, runs);
  Eigen::VectorXd theta0 = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(pn.size()));
  for (std::size_t i = 0; i < pn.size(); ++i) {
    const auto it = new_own_to_pool.find(pn[i]);
    const auto v = value_of.find(it != new_own_to_pool.end() ? it->second : pn[i]);
    if (v != value_of.end()) theta0(static_cast<Eigen::Index>(i)) = v->second;
  }
  return fit_output_error(s, runs, theta0, o, file);
}

double sse(const MLResult& m) { return 2.0 * m.summary.cost; }

}  // namespace

MLResult refine_structure_output_error(const UnsteadyStructure& pool,
                                       const std::vector<PreparedRun>& runs, MLResult ml,
                                       const FitOptions& o, const std::string& file,
                                       OutputErrorStepwiseResult* log) {
  const std::vector<std::string> pool_names = pool_names_of(pool, pool);
  std::map<std::string, int> moves;  // entries + removals per term: at most 4 each
  const double n = static_cast<double>(ml.summary.n_samples);
  for (int round = 0; round < 4 * static_cast<int>(pool_names.size()) + 4; ++round) {
    bool changed = false;
    std::vector<std::string> current = pool_names_of(pool, ml.structure);
    // Entry.
    double best_f = -std::numeric_limits<double>::infinity();
    std::string best_name;
    MLResult best;
    for (const std::string& c : pool_names) {
      if (std::find(current.begin(), current.end(), c) != current.end() || moves[c] >= 4) continue;
      std::vector<std::string> names = current;
      names.push_back(c);
      MLResult trial;
      try {
        trial = fit_names(pool, names, runs, ml, o, file);
      } catch (const InputError&) {
        continue;
      }
      const double p1 = static_cast<double>(trial.theta.size());
      if (!std::isfinite(trial.summary.cost) || !(n > p1)) continue;
      const double f = (sse(ml) - sse(trial)) / (sse(trial) / (n - p1));
      if (f > best_f) {
        best_f = f;
        best_name = c;
        best = std::move(trial);
      }
    }
    if (!best_name.empty() && best_f > o.f_to_enter) {
      log->steps.push_back({OutputErrorStepwiseStep::Action::entered, best_name, best_f, sse(ml), sse(best)});
      ++moves[best_name];
      ml = std::move(best);
      current = pool_names_of(pool, ml.structure);
      changed = true;
    }
    // Removal.
    double worst_f = std::numeric_limits<double>::infinity();
    std::string worst_name;
    for (const Named& term : refinable_terms(pool, ml.structure)) {
      const std::string& name = term.pool;
      if (moves[name] >= 4) continue;
      std::vector<std::string> rest = current;
      rest.erase(std::find(rest.begin(), rest.end(), name));
      const Counts c = counts(pool, rest);
      if (c.a == 0 || c.b1 == 0) continue;  // why: the model needs an a(x) and a b1(x)
      const auto at = std::find(ml.names.begin(), ml.names.end(), term.own);
      if (at == ml.names.end()) continue;
      const auto i = static_cast<std::size_t>(at - ml.names.begin());
      const auto k = static_cast<Eigen::Index>(i);
      const double sd = std::sqrt(ml.cov_white(k, k));
      // Why 0 for an unidentifiable term: the data cannot tell it from the others, so it is
      // the first to go.
      const double f = (ml.identifiability[i] == Identifiability::identified && sd > 0.0)
                           ? (ml.theta(k) / sd) * (ml.theta(k) / sd)
                           : 0.0;
      if (f < worst_f) {
        worst_f = f;
        worst_name = name;
      }
    }
    if (!worst_name.empty() && worst_f < o.f_to_remove) {
      std::vector<std::string> rest = current;
      rest.erase(std::find(rest.begin(), rest.end(), worst_name));
      MLResult refit;
      bool fitted = true;
      try {
        refit = fit_names(pool, rest, runs, ml, o, file);
      } catch (const InputError&) {
        fitted = false;
      }
      if (fitted && std::isfinite(refit.summary.cost)) {
        log->steps.push_back({OutputErrorStepwiseStep::Action::removed, worst_name, worst_f, sse(ml), sse(refit)});
        ++moves[worst_name];
        ml = std::move(refit);
        changed = true;
      }
    }
    if (!changed) break;
  }
  log->selected = pool_names_of(pool, ml.structure);
  return ml;
}

}  // namespace indicial::fit_detail
