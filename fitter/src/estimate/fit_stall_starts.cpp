// fit_stall_starts.cpp -- the starts of the stall start grid (FitOptions::stall_start_search,
// fit.hpp, which says why a search). The grid varies the time constants that decide WHERE in
// the cycle the separation lags and the vortex sheds and decays: T1 (and T1r with it), T2 and T_v, each a
// multiple of its configured start (l / V units, so the same grid at every airspeed). Not
// varied, to keep the grid at 18 fits: T_vl, C_N1 (the polar's own start, stall_polar.cpp)
// and the output gains (linear in the output). Whether varying T_vl or C_N1 too would find
// lower minima was not measured. The factors are the ones tried on the Glasgow fit cycles of
// tools/validate_stall.py (C_m with a constant C_mq: the lowest cost came from T_v x 2, T1 x
// {1/2, 1}, T2 x 1; C_L: every start of T1 x {1/2, 1, 2}, T_v x {1/2, 1, 2} but one ended at
// the same minimum); a finer grid was not measured.
#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "estimate/fit_internal.hpp"

namespace indicial::fit_detail {

bool stall_start_search_runs(const ParameterLayout& L, const FitOptions& o) {
  if (o.stall_start_search != StallStartSearch::grid) return false;
  if (L.structure().stall.families == StallFamilies::none) return false;
  // A start the caller chose for a stall parameter is theirs: no search.
  const std::vector<std::string> names = L.names();
  for (const auto& [name, value] : o.start_values)
    for (int i = 0; i < L.size(); ++i)
      if (names[static_cast<std::size_t>(i)] == name && is_stall_parameter(L.ids()[static_cast<std::size_t>(i)]))
        return false;
  return true;
}

std::vector<StallStartGridPoint> stall_start_grid(const ParameterLayout& L, const Eigen::VectorXd& theta0) {
  struct Axis {
    ParamKind kind;
    std::vector<double> factors;  // the first is 1: the configured start comes first
  };
  const Axis axes[] = {{ParamKind::stall_tau1, {1.0, 0.5, 2.0}},
                       {ParamKind::vortex_decay, {1.0, 0.5, 2.0}},
                       {ParamKind::stall_tau2, {1.0, 1.0 / 3.0}}};
  const std::vector<std::string> names = L.names();
  auto index_of = [&](ParamKind kind) {
    for (int i = 0; i < L.size(); ++i)
      if (L.ids()[static_cast<std::size_t>(i)].kind == kind) return i;
    return -1;  // held (model.stall_known) or not in the families
  };
  // T1r (model.stall_reattachment) moves with T1: a point whose T1r starts equal to its T1 is
  // the symmetric model's start of the same point. (Not a guarantee of a lower minimum: on the
  // Glasgow C_m fit cycles the grid with T1r kept 0.0342 where the symmetric grid kept 0.0312.)
  const int reattach = index_of(ParamKind::stall_tau1_reattach);
  std::vector<StallStartGridPoint> grid{{{}, theta0}};
  for (const Axis& axis : axes) {
    const int index = index_of(axis.kind);
    if (index < 0) continue;
    std::vector<StallStartGridPoint> next;
    for (const StallStartGridPoint& p : grid)
      for (double f : axis.factors) {
        StallStartGridPoint q = p;
        q.theta(index) = theta0(index) * f;
        if (axis.kind == ParamKind::stall_tau1 && reattach >= 0) q.theta(reattach) = theta0(reattach) * f;
        q.varied.emplace_back(names[static_cast<std::size_t>(index)], q.theta(index));
        // A zero start (T2 may start at 0) scales to itself: one point, not two.
        const bool duplicate = f != 1.0 && q.theta(index) == theta0(index);
        if (!duplicate) next.push_back(std::move(q));
      }
    grid = std::move(next);
  }
  return grid;
}

}  // namespace indicial::fit_detail
