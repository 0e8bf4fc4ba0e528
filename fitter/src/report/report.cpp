// report.cpp -- write_fit_outputs: fit.json, model.coef, report.md and the plots, in that
// order of failure (see report.hpp). The parts are in replay_check.cpp, report_json.cpp,
// report_markdown.cpp and plots.cpp (report_internal.hpp).
#include "indicial/fitter/report.hpp"

#include "indicial/fitter/model_merge.hpp"
#include "report/report_internal.hpp"

namespace fs = std::filesystem;

namespace indicial {

std::string report_detail::display_path(const std::string& path, const Experiment& e) {
  const fs::path base = fs::path(e.path).parent_path().lexically_normal();
  const fs::path rel = fs::path(path).lexically_normal().lexically_relative(base);
  // Why the checks: a path outside the experiment's directory (or on another root) keeps its
  // full form rather than a confusing ../../ chain.
  if (base.empty() || rel.empty() || *rel.begin() == "..") return path;
  return rel.string();
}

using report_detail::make_plots;
using report_detail::report_markdown;

FitOutputs write_fit_outputs(const FitResult& r, const Experiment& e, const FitOptions& o,
                             const fs::path& dir, Overwrite overwrite, const ReportOptions& ro) {
  FitOutputs w;
  w.dir = dir;
  // Everything that can fail on the model comes before the output directory is touched.
  w.model_coef = with_provenance_header(model_coef_text(r, e.path), ro.provenance);
  w.runtime = replay_in_runtime(r, e, w.model_coef);
  OutputDir out(dir, overwrite);
  const PlotSet ps = make_plots(r, e, out, ro);
  w.plots = ps.status;
  w.plot_message = ps.message;
  w.images = ps.images;
  nlohmann::json j = with_provenance_and_warnings(fit_json(r, e, o, &w.runtime), ro);
  if (!ro.experiment_display.empty()) j["experiment"]["path"] = ro.experiment_display;
  j["plots"] = {{"status", plot_status_name(ps.status)}, {"message", ps.message}, {"images", ps.images}};
  w.fit_json = j.dump(2) + "\n";
  w.report_md = report_markdown(r, e, o, w.runtime, ps, ro);
  out.write("fit.json", w.fit_json);
  out.write("model.coef", w.model_coef);
  out.write("report.md", w.report_md);
  out.commit();
  return w;
}

}  // namespace indicial
