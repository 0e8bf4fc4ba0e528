// The dynamic-stall campaign generator. See indicial/fitter/dynamic_stall.hpp.
#include "indicial/fitter/dynamic_stall.hpp"

#include <algorithm>
#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <fmt/format.h>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial::dynamic_stall {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kRadToDeg = 180.0 / kPi;

// The reference integrator's tolerance (docs/architecture.md: 1e-11 abs and rel).
constexpr double kTolerance = 1e-11;

struct Motion {
  double mean_rad, amplitude_rad, omega_radps;
  double alpha(double t) const { return mean_rad - amplitude_rad * std::cos(omega_radps * t); }
  double alpha_dot(double t) const { return amplitude_rad * omega_radps * std::sin(omega_radps * t); }
};

Motion motion_of(const Campaign& c, const PitchCycle& p) {
  return {p.mean_deg * kDegToRad, p.amplitude_deg * kDegToRad, 2.0 * kPi * c.frequency_hz(p)};
}

// The raw (not yet averaged) samples of one cycle's steady-state record: cycles_averaged
// cycles of samples_per_cycle samples, after transient_cycles, from the GK integration.
SimulatedRun integrate_cycle(const Campaign& c, const PitchCycle& p) {
  namespace odeint = boost::numeric::odeint;
  using State = std::array<double, 1>;
  const AirfoilConstants& a = c.airfoil;
  const Motion m = motion_of(c, p);
  const double semichord_s = c.reference_length_m() / p.airspeed_mps;
  const double tau1_s = a.tau1_semichords * semichord_s;
  const double tau2_s = a.tau2_semichords * semichord_s;
  auto rhs = [&](const State& f, State& dfdt, double t) {
    dfdt[0] = (static_separation(a, m.alpha(t) - tau2_s * m.alpha_dot(t)) - f[0]) / tau1_s;
  };
  const int n = c.samples_per_cycle;
  const double period_s = 1.0 / c.frequency_hz(p);
  const double dt_s = period_s / n;
  const std::size_t total = static_cast<std::size_t>(c.cycles_averaged) * static_cast<std::size_t>(n);
  SimulatedRun out;
  out.time_s.resize(total);
  out.motion_angle_rad.resize(total);
  out.rate_radps.resize(total);
  out.x_rad.resize(total);
  out.xdot_radps.resize(total);
  out.y_true.assign(2, std::vector<double>(total));
  out.coefficient_true.assign(2, std::vector<double>(total));
  // Starts at rest in the static state at alpha(0) (alpha_dot(0) = 0).
  State f{static_separation(a, m.alpha(0.0))};
  auto stepper = odeint::make_controlled(kTolerance, kTolerance, odeint::runge_kutta_dopri5<State>());
  double t = 0.0;
  const double t_first = c.transient_cycles * period_s;
  odeint::integrate_adaptive(stepper, rhs, f, t, t_first, dt_s / 4.0);
  for (std::size_t k = 0; k < total; ++k) {
    // Why the product, not repeated addition: the sample times stay exactly on the grid.
    const double tk = t_first + static_cast<double>(k) * dt_s;
    if (k > 0) odeint::integrate_adaptive(stepper, rhs, f, t, tk, dt_s / 4.0);
    t = tk;
    const double alpha = m.alpha(tk);
    const Coefficients now = airfoil_coefficients(a, alpha, f[0]);
    const Coefficients steady = airfoil_coefficients(a, alpha, static_separation(a, alpha));
    out.time_s[k] = tk - t_first;
    out.motion_angle_rad[k] = out.x_rad[k] = alpha;
    out.rate_radps[k] = out.xdot_radps[k] = m.alpha_dot(tk);
    out.coefficient_true[0][k] = now.lift;
    out.coefficient_true[1][k] = now.moment;
    out.y_true[0][k] = now.lift - steady.lift;
    out.y_true[1][k] = now.moment - steady.moment;
  }
  out.coefficient_measured = out.coefficient_true;
  return out;
}

// Averages the raw record over its cycles into one cycle.
PhaseAveragedCycle average_cycle(const Campaign& c, const PitchCycle& p, const SimulatedRun& raw) {
  const int n = c.samples_per_cycle;
  const auto nn = static_cast<std::size_t>(n);
  PhaseAveragedCycle out;
  out.cycle = p;
  out.frequency_hz = c.frequency_hz(p);
  const Motion m = motion_of(c, p);
  std::vector<std::vector<double>> sum(2, std::vector<double>(nn, 0.0));
  std::vector<std::vector<double>> sum_true(2, std::vector<double>(nn, 0.0));
  for (std::size_t k = 0; k < raw.time_s.size(); ++k) {
    for (std::size_t ci = 0; ci < 2; ++ci) {
      sum[ci][k % nn] += raw.coefficient_measured[ci][k];
      sum_true[ci][k % nn] += raw.coefficient_true[ci][k];
    }
  }
  const double cycles = static_cast<double>(c.cycles_averaged);
  for (std::size_t i = 0; i < nn; ++i) {
    const double phase = 2.0 * kPi * static_cast<double>(i) / n;
    const double t = phase / m.omega_radps;
    // Why divide by the inverse: round(x / 0.01) / 100 is the double nearest the printed
    // decimal (0.3, not 0.30000000000000004), as a file rounded to 0.01 rad reads back.
    out.phase_rad.push_back(std::round(phase / c.phase_resolution_rad) / std::round(1.0 / c.phase_resolution_rad));
    out.alpha_rad.push_back(m.alpha(t));
    out.q_radps.push_back(m.alpha_dot(t));
    out.lift.push_back(sum[0][i] / cycles);
    out.moment.push_back(sum[1][i] / cycles);
    out.lift_true.push_back(sum_true[0][i] / cycles);
    out.moment_true.push_back(sum_true[1][i] / cycles);
    const Coefficients s = airfoil_coefficients(c.airfoil, m.alpha(t), static_separation(c.airfoil, m.alpha(t)));
    out.lift_static.push_back(s.lift);
    out.moment_static.push_back(s.moment);
  }
  return out;
}

PitchCycle cycle(double amplitude_deg, double k, double airspeed_mps, CycleRole role) {
  PitchCycle p;
  p.mean_deg = 12.0;
  p.amplitude_deg = amplitude_deg;
  p.reduced_frequency = k;
  p.airspeed_mps = airspeed_mps;
  p.role = role;
  p.file = fmt::format("a{:g}_k{:.3f}_v{:g}.csv", amplitude_deg, k, airspeed_mps);
  return p;
}

std::string cycle_csv(const PhaseAveragedCycle& cy, const std::vector<std::string>& comments) {
  std::vector<CsvColumn> cols;
  cols.push_back({"phase_rad", cy.phase_rad});
  CsvColumn alpha{"alpha_deg", cy.alpha_rad};
  for (double& v : alpha.values) v *= kRadToDeg;
  CsvColumn q{"q_degps", cy.q_radps};
  for (double& v : q.values) v *= kRadToDeg;
  cols.push_back(alpha);
  cols.push_back(q);
  cols.push_back({"CL", cy.lift});
  cols.push_back({"Cm", cy.moment});
  cols.push_back({"CL_true", cy.lift_true});
  cols.push_back({"Cm_true", cy.moment_true});
  return write_run_csv(cols, comments);
}

const char* role_name(CycleRole r) { return r == CycleRole::fit ? "fit" : "holdout"; }

// The experiment file of one coefficient, with the agreed run-table keys (reduced_frequency,
// airspeed_mps) for the fit cycles.
std::string experiment_text(const Campaign& c, const std::string& coefficient,
                            const std::vector<std::string>& comments) {
  Experiment e = campaign_experiment_config(c, coefficient);
  e.static_curve.table_path = "static.csv";
  const std::string base = write_experiment_toml(e, comments);
  std::string runs = "runs = [";
  bool first = true;
  for (const PitchCycle& p : c.cycles) {
    if (p.role != CycleRole::fit) continue;
    runs += fmt::format("{}{{file = \"{}\", reduced_frequency = {}, airspeed_mps = {}}}", first ? "" : ", ",
                        p.file, format_double(p.reduced_frequency), format_double(p.airspeed_mps));
    first = false;
  }
  runs += "]\n";
  // Why the splice: write_experiment_toml writes the runs line from Run fields that do not
  // carry the phase-averaged keys; it is the only line replaced.
  const std::size_t at = base.find("runs = [");
  const std::size_t end = base.find('\n', at);
  if (at == std::string::npos || end == std::string::npos)
    throw InputError("experiment.toml", 0, "internal: the writer's runs line was not found");
  return base.substr(0, at) + runs + base.substr(end + 1);
}

}  // namespace

double Campaign::frequency_hz(const PitchCycle& p) const {
  return frequency_hz_from_reduced(p.reduced_frequency, p.airspeed_mps, reference_length_m());
}

const Campaign& default_campaign() {
  static const Campaign campaign = [] {
    Campaign c;
    const double ks[] = {0.02, 0.04, 0.06, 0.08, 0.10, 0.12, 0.15};
    // Hold-out airspeeds cycle through 25, 35, 30 m/s so predictions cross airspeeds; the fit
    // cycles are at 25, 30 and 35 m/s too (k = 0.04, 0.08, 0.12), so the fit itself sees runs
    // at several airspeeds (the runs table's airspeed_mps, issue 12).
    const double speeds[] = {25.0, 35.0, 30.0};
    int next_speed = 0;
    for (double k : ks) {
      const double fit_speed = k == 0.04 ? 25.0 : k == 0.08 ? 30.0 : k == 0.12 ? 35.0 : 0.0;
      const bool fit = fit_speed > 0.0;
      c.cycles.push_back(cycle(8.0, k, fit ? fit_speed : speeds[next_speed++ % 3],
                               fit ? CycleRole::fit : CycleRole::holdout));
    }
    for (double k : ks) c.cycles.push_back(cycle(6.0, k, speeds[next_speed++ % 3], CycleRole::holdout));
    return c;
  }();
  return campaign;
}

double static_separation(const AirfoilConstants& a, double alpha_rad) {
  const double alpha_deg = std::fabs(alpha_rad) * kRadToDeg;
  if (alpha_deg <= a.alpha1_deg) return 1.0 - 0.3 * std::exp((alpha_deg - a.alpha1_deg) / a.s1_deg);
  return 0.04 + 0.66 * std::exp((a.alpha1_deg - alpha_deg) / a.s2_deg);
}

Coefficients airfoil_coefficients(const AirfoilConstants& a, double alpha_rad, double f) {
  const double fc = std::clamp(f, 0.0, 1.0);
  const double root = std::sqrt(fc);
  const double s = std::sin(alpha_rad);
  const double normal = a.normal_force_slope_per_rad * s * 0.25 * (1.0 + root) * (1.0 + root);
  const double chord = a.suction_recovery * a.normal_force_slope_per_rad * s * s * root;
  Coefficients out;
  out.lift = normal * std::cos(alpha_rad) + chord * s;
  out.moment = a.cm0 + normal * (a.k0 + a.k1 * (1.0 - fc) + a.k2 * std::sin(kPi * std::pow(fc, a.m_exponent)));
  return out;
}

std::vector<PhaseAveragedCycle> simulate_campaign(const Campaign& c, double snr, std::uint64_t seed,
                                                  const NoiseModel& noise, std::vector<double>* sigma_out) {
  std::vector<SimulatedRun> raw;
  for (const PitchCycle& p : c.cycles) raw.push_back(integrate_cycle(c, p));
  const std::vector<double> sigma = add_measurement_noise(raw, snr, seed, noise);
  if (sigma_out) *sigma_out = sigma;
  std::vector<PhaseAveragedCycle> out;
  for (std::size_t i = 0; i < raw.size(); ++i) out.push_back(average_cycle(c, c.cycles[i], raw[i]));
  return out;
}

StaticPolar static_polar(const Campaign& c) {
  StaticPolar s;
  const int n = static_cast<int>(std::lround(c.static_max_deg / c.static_step_deg));
  for (int i = 0; i <= n; ++i) {
    const double alpha = i * c.static_step_deg * kDegToRad;
    const Coefficients v = airfoil_coefficients(c.airfoil, alpha, static_separation(c.airfoil, alpha));
    s.alpha_rad.push_back(alpha);
    s.lift.push_back(v.lift);
    s.moment.push_back(v.moment);
  }
  return s;
}

Experiment campaign_experiment_config(const Campaign& c, const std::string& coefficient) {
  if (coefficient != "CL" && coefficient != "Cm")
    throw InputError("--coefficient", 0, "the dynamic-stall campaign has CL and Cm, not '" + coefficient + "'");
  Experiment e;
  e.path = "dynamic-stall-" + coefficient + " (simulated)";
  e.axis = Axis::pitch;
  e.coefficient = coefficient;
  e.reference_length_m = c.reference_length_m();
  e.airspeed_mps = c.reference_airspeed_mps;
  const StaticPolar polar = static_polar(c);
  e.static_curve.kind = StaticKind::table;
  e.static_curve.table_path = "static polar (simulated)";
  e.static_curve.table_x_rad = polar.alpha_rad;
  e.static_curve.table_value = coefficient == "CL" ? polar.lift : polar.moment;
  e.rotary.polynomial = {0.0};
  e.rotary.estimate = false;
  e.model.a = SplineConfig{{0, 1, 2}, {10.0 * kDegToRad, 14.0 * kDegToRad, 17.0 * kDegToRad}, 2};
  e.model.b1 = SplineConfig{{0}, {}, 1};
  e.model.structure = StructureMode::fixed;
  return e;
}

Experiment campaign_experiment(const Campaign& c, const std::vector<PhaseAveragedCycle>& cycles,
                               const std::string& coefficient, CycleRole role) {
  Experiment e = campaign_experiment_config(c, coefficient);
  for (const PhaseAveragedCycle& cy : cycles) {
    if (cy.cycle.role != role) continue;
    Run r;
    r.path = cy.cycle.file;
    const double dt_s = 1.0 / (cy.frequency_hz * static_cast<double>(cy.phase_rad.size()));
    for (std::size_t i = 0; i < cy.phase_rad.size(); ++i) r.time_s.push_back(static_cast<double>(i) * dt_s);
    r.motion_angle_rad = cy.alpha_rad;
    r.rate_radps = cy.q_radps;
    r.rate_from_file = true;
    r.coefficient = coefficient == "CL" ? cy.lift : cy.moment;
    r.periodic = true;
    r.airspeed_mps = cy.cycle.airspeed_mps;
    e.runs.push_back(std::move(r));
  }
  set_data_range(e);
  return e;
}

std::vector<double> write_campaign(const Campaign& c, const std::string& out_dir, double snr,
                                   std::uint64_t seed, const NoiseModel& noise, Overwrite overwrite) {
  OutputDir out(out_dir, overwrite);
  std::vector<double> sigma;
  const std::vector<PhaseAveragedCycle> cycles = simulate_campaign(c, snr, seed, noise, &sigma);
  std::vector<std::string> comments = {
      "indicial simulate --case dynamic-stall: Goman-Khrabrov separation-point model, NACA 0012-like "
      "(fitter/include/indicial/fitter/dynamic_stall.hpp)",
      "truth integrated by Dormand-Prince 5(4), abs/rel tolerance 1e-11; " +
          std::to_string(c.cycles_averaged) + " cycles of " + std::to_string(c.samples_per_cycle) +
          " samples ensemble-averaged after " + std::to_string(c.transient_cycles) + " transient cycles",
      "noise " + noise_spec_text(noise) + " on the raw samples, SNR " + format_double(snr) + ", seed " +
          std::to_string(seed) + ": sigma CL " + format_double(sigma.at(0)) + ", Cm " +
          format_double(sigma.at(1)) + " (marginal std, RMS(C - C_static) / SNR)"};
  std::string table = "file,role,mean_deg,amplitude_deg,reduced_frequency,airspeed_mps,frequency_hz\n";
  for (const PhaseAveragedCycle& cy : cycles) {
    std::vector<std::string> cc = comments;
    cc.push_back(fmt::format("cycle: mean {} deg, amplitude {} deg, k = {}, airspeed {} m/s, f = {} Hz ({})",
                             cy.cycle.mean_deg, cy.cycle.amplitude_deg, cy.cycle.reduced_frequency,
                             cy.cycle.airspeed_mps, format_double(cy.frequency_hz), role_name(cy.cycle.role)));
    out.write(cy.cycle.file, cycle_csv(cy, cc));
    table += fmt::format("{},{},{},{},{},{},{}\n", cy.cycle.file, role_name(cy.cycle.role), cy.cycle.mean_deg,
                         cy.cycle.amplitude_deg, cy.cycle.reduced_frequency, cy.cycle.airspeed_mps,
                         format_double(cy.frequency_hz));
  }
  const StaticPolar polar = static_polar(c);
  std::vector<double> deg = polar.alpha_rad;
  for (double& v : deg) v *= kRadToDeg;
  out.write("static.csv", write_run_csv({{"alpha_deg", deg}, {"CL", polar.lift}, {"Cm", polar.moment}},
                                        {"static polar of the dynamic-stall case (f = f0(alpha)), no noise"}));
  out.write("cycles.csv", table);
  for (const char* coef : {"CL", "Cm"}) {
    std::vector<std::string> cc = comments;
    cc.push_back("the fit cycles; the hold-out cycles are listed in cycles.csv");
    out.write(std::string("experiment-") + coef + ".toml", experiment_text(c, coef, cc));
  }
  out.commit();
  return sigma;
}

}  // namespace indicial::dynamic_stall
