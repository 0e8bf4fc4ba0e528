// Runtime acceptance of fitted models and input-time capacity checks. See
// indicial/fitter/runtime_limits.hpp.
#include "indicial/fitter/runtime_limits.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "indicial/fitter/error.hpp"
#include "indicial/runtime.hpp"

namespace indicial {
namespace {

template <class Cap>
LoadStatus load_status_at(const ModelSet<double, FitCapacity>& model, std::string& reason) {
  auto predictor = std::make_unique<Predictor<double, Cap>>();
  ParseDiagnostic diag;
  std::vector<char> buffer(1 << 16);
  std::size_t length = 0;
  const WriteStatus ws = write_coef_file(model, buffer.data(), buffer.size(), &length);
  if (ws != WriteStatus::ok) {
    reason = std::string("the model cannot be written as a coefficient file: ") + to_string(ws);
    return LoadStatus::invalid_value;
  }
  const LoadStatus s = predictor->load(buffer.data(), length, &diag);
  if (s != LoadStatus::ok) reason = diag.reason;
  return s;
}

}  // namespace

RuntimeAcceptance runtime_acceptance(const ModelSet<double, FitCapacity>& model) {
  RuntimeAcceptance a;
  std::string small_reason;
  // Why through the file text: that is exactly what the runtime will be given.
  if (load_status_at<DefaultCapacity>(model, small_reason) == LoadStatus::ok) {
    a.capacity = RuntimeCapacity::default_capacity;
    return a;
  }
  std::string big_reason;
  const LoadStatus big = load_status_at<FitCapacity>(model, big_reason);
  if (big == LoadStatus::ok) {
    a.capacity = RuntimeCapacity::fit_capacity_only;
    a.reason = "the default Predictor<> refuses it (" + small_reason +
               "); it needs Predictor<double, FitCapacity>";
    return a;
  }
  a.capacity = RuntimeCapacity::refused;
  a.status = big;
  a.reason = big_reason;
  return a;
}

RuntimeAcceptance require_runtime_accepts(const ModelSet<double, FitCapacity>& model,
                                          const std::string& file_label, ModelFile role) {
  RuntimeAcceptance a = runtime_acceptance(model);
  if (a.capacity == RuntimeCapacity::refused)
    throw InputError(file_label, 0,
                     std::string(role == ModelFile::to_write ? "not written: " : "") +
                         "the runtime refuses the model: " + a.reason + " (" + to_string(a.status) + ")");
  return a;
}

double min_lag_decay(const CoefficientModel<double, FitCapacity>& m, int lag, double x_min_rad,
                     double x_max_rad) {
  const auto& b = m.lags[lag].b;
  double lowest = HUGE_VAL;
  // Why the negated test: a NaN value must read as infeasible, not vanish in a min().
  auto take = [&](double x) {
    const double v = spline_value(b, x);
    lowest = !(v >= lowest) ? (std::isnan(v) ? -HUGE_VAL : v) : lowest;
  };
  for (int i = 0; i <= validation_samples; ++i)
    take(x_min_rad + (x_max_rad - x_min_rad) * (static_cast<double>(i) / validation_samples));
  for (int k = 0; k < b.n_knots; ++k) {
    for (double x : {std::nextafter(b.knot_rad[k], -HUGE_VAL), std::nextafter(b.knot_rad[k], HUGE_VAL)})
      if (x >= x_min_rad && x <= x_max_rad) take(x);
  }
  return lowest;
}

bool lag_decay_positive(const CoefficientModel<double, FitCapacity>& m, double x_min_rad, double x_max_rad) {
  for (int j = 0; j < m.n_lags; ++j)
    if (!(min_lag_decay(m, j, x_min_rad, x_max_rad) > 0.0)) return false;
  return true;
}

}  // namespace indicial
