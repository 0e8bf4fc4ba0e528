// fit_params.cpp -- parameter identity and the parameter layout: what every estimated number
// is (ParamId), its contract name (parameter_name, the one place names are made, and
// parse_parameter_name, the one place they are read), the term lists of a structure and the
// ParameterLayout that orders them into the output-error parameter vector.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <stdexcept>
#include <tuple>

#include "estimate/fit_internal.hpp"

namespace indicial {

namespace {
bool is_knot(ParamKind k) {
  return k == ParamKind::a_knot || k == ParamKind::b_knot || k == ParamKind::rotary_knot ||
         k == ParamKind::static_knot || k == ParamKind::f0_knot;
}
// The identity fields: a knot is where it is (not its display number); run only for states.
auto identity(const ParamId& p) {
  const bool knot = is_knot(p.kind);
  return std::make_tuple(static_cast<int>(p.kind), p.lag, p.power, knot ? p.knot_rad : 0.0,
                         p.kind == ParamKind::initial_state ? p.run : 0);
}
}  // namespace

bool same_parameter(const ParamId& x, const ParamId& y) { return identity(x) == identity(y); }
bool operator<(const ParamId& x, const ParamId& y) { return identity(x) < identity(y); }

std::size_t ParamIdHash::operator()(const ParamId& id) const {
  const auto [kind, lag, power, knot, run] = identity(id);
  std::size_t h = std::hash<int>()(kind);
  for (std::size_t v : {std::hash<int>()(lag), std::hash<int>()(power), std::hash<double>()(knot),
                        std::hash<int>()(run)})
    h = h * 1000003u ^ v;
  return h;
}

std::string parameter_name(const ParamId& id) {
  const std::string lag = std::to_string(id.lag + 1);
  const std::string power = std::to_string(id.power);
  const std::string knot = std::to_string(id.knot + 1);
  switch (id.kind) {
    case ParamKind::a_power: return "a" + power;
    case ParamKind::a_knot: return "A" + knot;
    case ParamKind::b_power: return "b" + lag + "_" + power;
    case ParamKind::b_knot: return id.lag == 0 ? "B" + knot : "B" + lag + "_" + knot;
    case ParamKind::con: return "con";
    case ParamKind::gain: return "c" + lag;
    case ParamKind::delay: return "delay_s";
    case ParamKind::rotary_power: return "Caq_" + power;
    case ParamKind::rotary_knot: return "CaqK" + knot;
    case ParamKind::static_power: return "dCa_" + power;
    case ParamKind::static_knot: return "dCaK" + knot;
    case ParamKind::initial_state: {
      const std::string run = "y0_" + std::to_string(id.run + 1);
      return id.lag == 0 ? run : run + "_" + lag;
    }
    case ParamKind::stall_tau1: return "T1";
    case ParamKind::stall_tau2: return "T2";
    case ParamKind::stall_tau1_reattach: return "T1r";
    case ParamKind::stall_reattach_shift: return "dxr";
    case ParamKind::stall_lag_limit: return "dxl";
    case ParamKind::f0_power: return "f0c_" + power;
    case ParamKind::f0_knot: return "f0cK" + knot;
    case ParamKind::stall_cp: return "k" + power;
    case ParamKind::shedding_threshold: return "CN1";
    case ParamKind::vortex_decay: return "Tv";
    case ParamKind::vortex_travel: return "Tvl";
    case ParamKind::vortex_lift: return "cv";
    case ParamKind::vortex_cp: return "xv";
  }
  return "?";
}

namespace {
// A cursor over a name: literal prefixes and decimal numbers.
struct NameScanner {
  const std::string& s;
  std::size_t pos = 0;
  bool literal(const char* p) {
    const std::size_t n = std::strlen(p);
    if (s.compare(pos, n, p) != 0) return false;
    pos += n;
    return true;
  }
  int number() {  // -1 when there are no digits (or too many)
    std::size_t end = pos;
    while (end < s.size() && end - pos < 6 && s[end] >= '0' && s[end] <= '9') ++end;
    if (end == pos) return -1;
    const int v = std::stoi(s.substr(pos, end - pos));
    pos = end;
    return v;
  }
};

// Reads the kind and numbers; parse_parameter_name checks the result by printing it back.
bool scan_name(NameScanner& c, ParamId& r) {
  if (c.literal("con")) { r.kind = ParamKind::con; return true; }
  // The dynamic-stall names (before the numbered prefixes: "cv" is no gain c{k}).
  struct Whole { const char* text; ParamKind kind; };
  static const Whole whole[] = {{"T1r", ParamKind::stall_tau1_reattach}, {"dxr", ParamKind::stall_reattach_shift},
                                {"dxl", ParamKind::stall_lag_limit},
                                {"T1", ParamKind::stall_tau1},       {"T2", ParamKind::stall_tau2},
                                {"CN1", ParamKind::shedding_threshold}, {"Tvl", ParamKind::vortex_travel},
                                {"Tv", ParamKind::vortex_decay},     {"cv", ParamKind::vortex_lift},
                                {"xv", ParamKind::vortex_cp}};
  for (const Whole& w : whole)
    if (c.literal(w.text)) { r.kind = w.kind; return true; }
  if (c.literal("k")) { r.kind = ParamKind::stall_cp; r.power = c.number(); return true; }
  if (c.literal("delay_s")) { r.kind = ParamKind::delay; return true; }
  if (c.literal("y0_")) {
    r.kind = ParamKind::initial_state;
    r.run = c.number() - 1;
    r.lag = c.literal("_") ? c.number() - 1 : 0;
    return true;
  }
  struct Prefix { const char* text; ParamKind kind; };
  static const Prefix numbered[] = {
      {"CaqK", ParamKind::rotary_knot}, {"Caq_", ParamKind::rotary_power},
      {"dCaK", ParamKind::static_knot}, {"dCa_", ParamKind::static_power},
      {"f0cK", ParamKind::f0_knot},     {"f0c_", ParamKind::f0_power},
      {"a", ParamKind::a_power},        {"A", ParamKind::a_knot},
      {"c", ParamKind::gain}};
  for (const Prefix& p : numbered) {
    if (!c.literal(p.text)) continue;
    r.kind = p.kind;
    const int v = c.number();
    if (p.kind == ParamKind::gain) r.lag = v - 1;
    else if (is_knot(p.kind)) r.knot = v - 1;
    else r.power = v;
    return true;
  }
  if (c.literal("b")) {
    r.kind = ParamKind::b_power;
    r.lag = c.number() - 1;
    return c.literal("_") && (r.power = c.number()) >= 0;
  }
  if (c.literal("B")) {
    r.kind = ParamKind::b_knot;
    const int first = c.number();
    if (c.literal("_")) {
      r.lag = first - 1;
      r.knot = c.number() - 1;
    } else {
      r.knot = first - 1;
    }
    return true;
  }
  return false;
}
}  // namespace

bool parse_parameter_name(const std::string& name, ParamId* id) {
  NameScanner c{name};
  ParamId r;
  if (!scan_name(c, r) || c.pos != name.size()) return false;
  if (r.lag < 0 || r.run < 0 || r.knot < 0 || r.power < 0) return false;
  if (r.kind == ParamKind::gain && r.lag < 1) return false;
  if (r.kind == ParamKind::stall_cp && r.power > 2) return false;
  if (is_knot(r.kind)) r.knot_rad = std::numeric_limits<double>::quiet_NaN();
  // Why print it back: one spelling per parameter ("b1_01", "B1_2" and "y0_1_1" are not names).
  if (parameter_name(r) != name) return false;
  *id = r;
  return true;
}

}  // namespace indicial

namespace indicial::fit_detail {

namespace {
void add_spline_terms(std::vector<ParamId>& out, const SplineTerms& s, ParamKind power_kind,
                      ParamKind knot_kind, int lag) {
  for (int p : s.powers) {
    ParamId t;
    t.kind = power_kind;
    t.lag = lag;
    t.power = p;
    out.push_back(t);
  }
  for (std::size_t j = 0; j < s.knots_rad.size(); ++j) {
    ParamId t;
    t.kind = knot_kind;
    t.lag = lag;
    t.power = s.knot_power;
    t.knot = static_cast<int>(j);
    t.knot_rad = s.knots_rad[j];
    out.push_back(t);
  }
}

SplineTerms spline_terms(const SplineConfig& c) {
  SplineTerms s;
  s.powers = c.powers;
  std::sort(s.powers.begin(), s.powers.end());
  s.powers.erase(std::unique(s.powers.begin(), s.powers.end()), s.powers.end());
  s.knots_rad = c.knots_rad;
  std::sort(s.knots_rad.begin(), s.knots_rad.end());
  s.knot_power = c.knot_power;
  return s;
}

}  // namespace

std::vector<ParamId> structural_terms(const UnsteadyStructure& s) {
  std::vector<ParamId> t;
  add_spline_terms(t, s.a, ParamKind::a_power, ParamKind::a_knot, 0);
  for (int j = 0; j < s.lags(); ++j) {
    add_spline_terms(t, s.b[static_cast<std::size_t>(j)], ParamKind::b_power, ParamKind::b_knot, j);
    if (j == 0 && s.con == Bias::present) t.push_back(param_id(ParamKind::con));
    if (j > 0) t.push_back(param_id(ParamKind::gain, j));
  }
  if (s.delay == DelayTerm::estimated) t.push_back(param_id(ParamKind::delay));
  // The dynamic-stall families: structural too (the output depends on their states).
  // Known ones (model.stall_known) are held: set by build_unsteady, not in the vector.
  auto add_stall = [&](const ParamId& id) {
    if (!s.stall.is_known(id)) t.push_back(id);
  };
  if (s.stall.families != StallFamilies::none) {
    add_stall(param_id(ParamKind::stall_tau1));
    add_stall(param_id(ParamKind::stall_tau2));
    if (s.stall.reattachment == StallReattachment::estimated) add_stall(param_id(ParamKind::stall_tau1_reattach));
    if (s.stall.hysteresis == StallHysteresis::estimated) add_stall(param_id(ParamKind::stall_reattach_shift));
    if (s.stall.lag_limit == StallLagLimit::estimated) add_stall(param_id(ParamKind::stall_lag_limit));
    add_spline_terms(t, s.stall.f0_correction, ParamKind::f0_power, ParamKind::f0_knot, 0);
    for (int k = 0; k < 3; ++k) {
      add_stall(param_id(ParamKind::stall_cp, 0, k));
    }
  }
  if (s.stall.families == StallFamilies::separation_and_vortex) {
    for (ParamKind k : {ParamKind::shedding_threshold, ParamKind::vortex_decay,
                        ParamKind::vortex_travel, ParamKind::vortex_lift, ParamKind::vortex_cp})
      add_stall(param_id(k));
  }
  return t;
}

bool is_stall_parameter(const ParamId& id) {
  switch (id.kind) {
    case ParamKind::stall_tau1:
    case ParamKind::stall_tau2:
    case ParamKind::stall_tau1_reattach:
    case ParamKind::stall_reattach_shift:
    case ParamKind::stall_lag_limit:
    case ParamKind::f0_power:
    case ParamKind::f0_knot:
    case ParamKind::stall_cp:
    case ParamKind::shedding_threshold:
    case ParamKind::vortex_decay:
    case ParamKind::vortex_travel:
    case ParamKind::vortex_lift:
    case ParamKind::vortex_cp: return true;
    // Every kind named (no default): a new kind must be placed here (-Wswitch).
    case ParamKind::a_power:
    case ParamKind::a_knot:
    case ParamKind::b_power:
    case ParamKind::b_knot:
    case ParamKind::con:
    case ParamKind::gain:
    case ParamKind::delay:
    case ParamKind::rotary_power:
    case ParamKind::rotary_knot:
    case ParamKind::static_power:
    case ParamKind::static_knot:
    case ParamKind::initial_state: return false;
  }
  return false;
}

bool is_stall_output_parameter(const ParamId& id) {
  return id.kind == ParamKind::stall_cp || id.kind == ParamKind::vortex_lift || id.kind == ParamKind::vortex_cp;
}

std::vector<ParamId> rotary_terms(const SplineTerms& pool) {
  std::vector<ParamId> t;
  add_spline_terms(t, pool, ParamKind::rotary_power, ParamKind::rotary_knot, 0);
  return t;
}

std::vector<ParamId> static_corr_terms(const SplineTerms& pool) {
  std::vector<ParamId> t;
  add_spline_terms(t, pool, ParamKind::static_power, ParamKind::static_knot, 0);
  return t;
}

std::vector<ParamId> output_terms(const UnsteadyStructure& s) {
  std::vector<ParamId> t = rotary_terms(s.rotary);
  const std::vector<ParamId> st = static_corr_terms(s.static_corr);
  t.insert(t.end(), st.begin(), st.end());
  return t;
}

BasisTerm term_basis(const ParamId& t) {
  switch (t.kind) {
    case ParamKind::a_power:
    case ParamKind::b_power:
    case ParamKind::rotary_power:
    case ParamKind::static_power: return BasisTerm{BasisKind::power, t.power, 0.0};
    case ParamKind::a_knot:
    case ParamKind::b_knot:
    case ParamKind::rotary_knot:
    case ParamKind::static_knot: return BasisTerm{BasisKind::knot, t.power, t.knot_rad};
    default: throw std::logic_error("term_basis: " + parameter_name(t) + " is no spline term");
  }
}

UnsteadyStructure structure_from_config(const ModelConfig& m) {
  UnsteadyStructure s;
  s.a = spline_terms(m.a);
  s.b = {spline_terms(m.b1)};
  s.con = m.bias ? Bias::present : Bias::absent;
  for (int k = 1; k < std::max(1, m.lags); ++k) {
    const auto j = static_cast<std::size_t>(k - 1);
    // Why the default: a further lag without its own b_k(x) is a constant time constant.
    s.b.push_back(j < m.further_lag_b.size() ? spline_terms(m.further_lag_b[j])
                                             : SplineTerms{{0}, {}, 1});
  }
  // Diagnose's extensions (experiment.hpp): ML-only terms.
  s.static_corr = spline_terms(m.static_correction);
  s.rotary = spline_terms(m.rotary_correction);
  if (s.rotary.size() > 0) s.rotary_role = RotaryRole::corrects_a_priori;
  s.delay = m.delay == DelayEstimation::estimated ? DelayTerm::estimated : DelayTerm::absent;
  s.further_lag_start = m.further_lag_start;
  s.stall = stall_structure(m.stall, m.stall.polar_path);
  return s;
}

UnsteadyStructure select_terms(const UnsteadyStructure& pool, const std::vector<ParamId>& ids) {
  auto has = [&](const ParamId& t) { return std::find(ids.begin(), ids.end(), t) != ids.end(); };
  // Further lags are not subject to selection (the equation error does not see them), nor are
  // the ML-only terms (delay, rotary correction, static correction).
  UnsteadyStructure s = pool;
  s.a = SplineTerms{{}, {}, pool.a.knot_power};
  s.b[0] = SplineTerms{{}, {}, pool.b[0].knot_power};
  s.con = Bias::absent;
  for (const ParamId& t : structural_terms(pool)) {
    if (!has(t)) continue;
    switch (t.kind) {
      case ParamKind::a_power: s.a.powers.push_back(t.power); break;
      case ParamKind::a_knot: s.a.knots_rad.push_back(t.knot_rad); break;
      case ParamKind::b_power:
        if (t.lag == 0) s.b[0].powers.push_back(t.power);
        break;
      case ParamKind::b_knot:
        if (t.lag == 0) s.b[0].knots_rad.push_back(t.knot_rad);
        break;
      case ParamKind::con: s.con = Bias::present; break;
      default: break;
    }
  }
  return s;
}

// ------------------------------------------------------------------------------------------
ParameterLayout::ParameterLayout(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs)
    : s_(s), ids_(structural_terms(s)) {
  n_struct_ = static_cast<int>(ids_.size());
  const std::vector<ParamId> out = output_terms(s);
  ids_.insert(ids_.end(), out.begin(), out.end());
  n_output_ = static_cast<int>(out.size());
  for (std::size_t r = 0; r < runs.size(); ++r) {
    if (runs[r].periodic) {
      y0_offset_.push_back(-1);
      continue;
    }
    y0_offset_.push_back(size());
    for (int j = 0; j < s.y0_per_run(); ++j) {
      ParamId y0;
      y0.kind = ParamKind::initial_state;
      y0.run = static_cast<int>(r);
      y0.lag = j;
      ids_.push_back(y0);
    }
  }
}

std::vector<std::string> ParameterLayout::names() const {
  std::vector<std::string> n;
  for (const ParamId& id : ids_) n.push_back(parameter_name(id));
  return n;
}

int ParameterLayout::find(const ParamId& id) const {
  const auto it = std::find(ids_.begin(), ids_.end(), id);
  return it == ids_.end() ? -1 : static_cast<int>(it - ids_.begin());
}

namespace {
// Adds coef * basis term into a double spline: powers into power_coef (n_powers grown), knots
// merged with an existing knot of the same position and power or appended.
void add_term(SplineD& sp, const ParamId& t, double coef, const char* what) {
  const BasisTerm b = term_basis(t);
  if (b.kind == BasisKind::power) {
    if (b.power >= Cap::max_powers) throw std::logic_error(std::string(what) + ": power too high");
    for (int i = sp.n_powers; i <= b.power; ++i) sp.power_coef[i] = 0.0;
    sp.n_powers = std::max(sp.n_powers, b.power + 1);
    sp.power_coef[b.power] += coef;
    return;
  }
  for (int j = 0; j < sp.n_knots; ++j)
    if (sp.knot_rad[j] == b.knot_rad && sp.knot_power[j] == b.power) {
      sp.knot_coef[j] += coef;
      return;
    }
  if (sp.n_knots >= Cap::max_knots) throw std::logic_error(std::string(what) + ": too many knots");
  sp.knot_rad[sp.n_knots] = b.knot_rad;
  sp.knot_power[sp.n_knots] = b.power;
  sp.knot_coef[sp.n_knots] = coef;
  ++sp.n_knots;
}
}  // namespace

CoefficientModel<double, Cap> unit_output_model(const ParamId& term) {
  CoefficientModel<double, Cap> m;
  const bool rotary = term.kind == ParamKind::rotary_power || term.kind == ParamKind::rotary_knot;
  add_term(rotary ? m.rotary : m.static_correction, term, 1.0, "unit output term");
  return m;
}

void ParameterLayout::add_output_terms(const double* theta, CoefficientModel<double, Cap>& m) const {
  const Range r = output();
  if (s_.rotary.size() > 0 && s_.rotary_role == RotaryRole::replaces_a_priori) m.rotary = SplineD{};
  for (int k = r.begin; k < r.end; ++k) {
    const ParamId& id = ids_[static_cast<std::size_t>(k)];
    const bool rotary = id.kind == ParamKind::rotary_power || id.kind == ParamKind::rotary_knot;
    add_term(rotary ? m.rotary : m.static_correction, id, theta[k], rotary ? "C_aq(x)" : "dC_a(x)");
  }
}

}  // namespace indicial::fit_detail
