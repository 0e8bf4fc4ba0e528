// `indicial coef check MODEL.coef`: parse and validate a coefficient file exactly as the
// runtime does (runtime/include/indicial/coef_file.hpp, Predictor::load) and print a summary.
// A refusal is reported as FILE:LINE: reason (status) and exits 1.
// `indicial coef merge A.coef B.coef ... --out AB.coef [--force]`: one model set from
// separately fitted coefficients of one axis (indicial::merge_model_sets: same axis, reference
// length, alpha0 and airspeed, distinct names, envelope = the intersection).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/provenance.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/runtime.hpp"

namespace {

constexpr double kDegPerRad = 57.29577951308232;

template <int P, int K>
std::string spline_summary(const indicial::Spline<double, P, K>& s) {
  if (s.n_powers == 0 && s.n_knots == 0) return "none";
  std::string r = std::to_string(s.n_powers) + " power" + (s.n_powers == 1 ? "" : "s");
  if (s.n_knots > 0) {
    r += " + knots at";
    for (int j = 0; j < s.n_knots; ++j) {
      char buf[48];
      std::snprintf(buf, sizeof buf, " %.4g deg (p=%d)", s.knot_rad[j] * kDegPerRad, s.knot_power[j]);
      r += buf;
    }
  }
  return r;
}
// The dynamic-stall families of a coefficient (version-2 files), one line.
void print_stall_summary(const indicial::StallModel<double, indicial::DefaultCapacity>& st) {
  if (st.families == indicial::StallFamilies::none) return;
  const auto& p = st.separation;
  std::printf("    dynamic stall: %s; f0 table of %d rows, C_Na %g /rad, T1 %g, T2 %g (semichords)",
              indicial::stall_families_name(st.families), p.n_f0, p.normal_force_slope_per_rad,
              p.tau1_semichords, p.tau2_semichords);
  if (p.tau1_reattach_semichords > 0.0) std::printf(", T1r %g (reattaching)", p.tau1_reattach_semichords);
  if (p.reattach_shift_rad > 0.0)
    std::printf(", static hysteresis dxr %g deg", p.reattach_shift_rad * 180.0 / 3.141592653589793);
  if (p.lag_limit_rad > 0.0) std::printf(", T2's lag limited to %g deg", p.lag_limit_rad * 180.0 / 3.141592653589793);
  if (p.forcing_lag != indicial::ForcingLag::delay)
    std::printf(", T2 a %s lag", indicial::forcing_lag_name(p.forcing_lag));
  if (st.families == indicial::StallFamilies::separation_and_vortex)
    std::printf("; vortex C_N1 %g, T_v %g, T_vl %g", st.vortex.shedding_threshold,
                st.vortex.decay_semichords, st.vortex.travel_semichords);
  std::printf("\n");
}


void run_check(const std::string& path) {
  using namespace indicial;
  const std::string text = read_text(path);
  auto model = std::make_unique<ModelSet<double, DefaultCapacity>>();
  ParseDiagnostic diag;
  LoadStatus st = parse_coef_file(text.data(), text.size(), model.get(), &diag);
  if (st == LoadStatus::checksum_mismatch) {
    const std::size_t at = text.rfind("\nchecksum ");
    const std::size_t covered = at == std::string::npos ? 0 : at + 1;
    char hex[16];
    std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(crc32(text.data(), covered)));
    throw InputError(path, static_cast<long>(diag.line),
                     std::string(diag.reason) + " (checksum_mismatch; the bytes before it give " +
                         hex + ")");
  }
  if (st == LoadStatus::ok) st = validate_for_runtime(*model, &diag);
  if (st != LoadStatus::ok)
    throw InputError(path, static_cast<long>(diag.line),
                     std::string(diag.reason) + " (" + to_string(st) + ")");
  const ModelSet<double, DefaultCapacity>& m = *model;
  std::printf("%s: ok, %zu bytes, runtime-valid (DefaultCapacity)\n", path.c_str(), text.size());
  std::printf("  axis %s, l = %g m, V_ref = %g m/s (l/V = %.5g s), alpha0 = %g deg\n", axis_name(m.axis),
              m.reference_length_m, m.airspeed_mps,
              airspeed_scaling(m.airspeed_mps, m.reference_length_m, m.airspeed_mps).l_over_v_s,
              m.alpha0_rad * kDegPerRad);
  std::printf("  envelope %g .. %g deg\n", m.x_min_rad * kDegPerRad, m.x_max_rad * kDegPerRad);
  for (int c = 0; c < m.n_coefficients; ++c) {
    const auto& cm = m.coefficients[c];
    std::printf("  %s: static %s; rotary %s; a(x) %s; %d lag%s", cm.name,
                cm.static_curve.kind == StaticKind::table
                    ? ("table of " + std::to_string(cm.static_curve.n_table) + " rows").c_str()
                    : spline_summary(cm.static_curve.polynomial).c_str(),
                spline_summary(cm.rotary).c_str(), spline_summary(cm.a).c_str(), cm.n_lags,
                cm.n_lags == 1 ? "" : "s");
    if (cm.con != 0.0) std::printf("; con %g", cm.con);
    std::printf("\n");
    for (int j = 0; j < cm.n_lags; ++j)
      std::printf("    b%d(x): %s, gain %g\n", j + 1, spline_summary(cm.lags[j].b).c_str(), cm.lags[j].gain);
    print_stall_summary(cm.stall);
  }
}

struct MergeCliOptions {
  std::vector<std::string> inputs;
  std::string out;
  bool force = false;
};

void run_merge(const MergeCliOptions& o) {
  using namespace indicial;
  if (o.inputs.size() < 2) throw InputError("merge", 0, "give at least two coefficient files");
  std::vector<ModelSet<double, FitCapacity>> models;
  models.reserve(o.inputs.size());
  for (const std::string& path : o.inputs) models.push_back(read_model_file(path));
  std::vector<NamedModelSet> parts;
  for (std::size_t i = 0; i < models.size(); ++i) parts.push_back({o.inputs[i], &models[i]});
  const ModelMerge merged = merge_model_sets(parts);
  for (const std::string& w : merged.warnings) std::fprintf(stderr, "indicial: warning: %s\n", w.c_str());
  refuse_output_onto_input(o.out, o.inputs);
  // Where the merged model came from, as a fitted model.coef says it: version, command line and
  // each input file's digest (role "model") in its header comments.
  Provenance provenance = make_provenance(tools::invocation(), tools::build_commit());
  for (const std::string& path : o.inputs) add_input(provenance, "model", path);
  write_file_atomically(o.out, with_provenance_header(coef_file_text(merged.model, o.out), provenance),
                        o.force ? Overwrite::replace : Overwrite::refuse);
  std::printf("%s: %d coefficients (", o.out.c_str(), merged.model.n_coefficients);
  for (int c = 0; c < merged.model.n_coefficients; ++c)
    std::printf("%s%s", c ? ", " : "", merged.model.coefficients[c].name);
  std::printf("), envelope %g .. %g deg\n", merged.model.x_min_rad * kDegPerRad, merged.model.x_max_rad * kDegPerRad);
}

const indicial::tools::RegisterCommand register_coef([](CLI::App& app) {
  CLI::App* coef = app.add_subcommand("coef", "Inspect coefficient files (.coef).");
  coef->require_subcommand(1);
  auto path = std::make_shared<std::string>();
  CLI::App* check = coef->add_subcommand(
      "check",
      "Parse and validate MODEL.coef exactly as the runtime does (syntax, capacity, checksum,\n"
      "b_j(x) > 0 over the envelope) and print a summary; exit 1 with FILE:LINE: reason if refused.");
  check->add_option("MODEL", *path, "coefficient file")->required();
  check->callback([path]() { run_check(*path); });
  auto merge_opt = std::make_shared<MergeCliOptions>();
  CLI::App* merge = coef->add_subcommand(
      "merge",
      "Merge separately fitted coefficient files of one axis into one model (the runtime steps\n"
      "all of them from one Predictor). Refused when the axis, reference length, alpha0 or\n"
      "airspeed differ (the field and both values named), when a coefficient repeats, when the\n"
      "envelopes do not overlap or there are more than 3 coefficients; the envelope is the\n"
      "intersection (a warning when it shrinks).");
  merge->add_option("MODELS", merge_opt->inputs, "coefficient files, in output order")->required();
  merge->add_option("--out", merge_opt->out, "the merged coefficient file")->required();
  merge->add_flag("--force", merge_opt->force, "replace an existing --out file");
  merge->callback([merge_opt]() { run_merge(*merge_opt); });
});

}  // namespace
