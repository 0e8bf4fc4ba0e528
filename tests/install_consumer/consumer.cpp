// Steps a model built in code through the installed runtime headers.
#include <cstdio>

#include "indicial/runtime.hpp"

int main() {
  indicial::ModelSet<double, indicial::DefaultCapacity> m{};
  m.x_min_rad = -1.0;
  m.x_max_rad = 1.0;
  m.n_coefficients = 1;
  m.coefficients[0].name[0] = 'C';
  m.coefficients[0].name[1] = 'm';
  m.coefficients[0].lags[0].b.n_powers = 1;
  m.coefficients[0].lags[0].b.power_coef[0] = 2.0;
  m.coefficients[0].a.n_powers = 1;
  m.coefficients[0].a.power_coef[0] = -1.0;
  static indicial::RuntimeModel<double, indicial::DefaultCapacity> model;
  if (indicial::make_runtime_model(m, &model) != indicial::LoadStatus::ok) return 1;
  indicial::State<double, indicial::DefaultCapacity> s;
  if (indicial::reset(model, s, 0.1, 1.0) != indicial::StepStatus::ok) return 2;
  double out[3];
  if (indicial::step(model, s, {0.2, 1.0, 1.0}, 0.1, out) != indicial::StepStatus::ok) return 3;
  std::printf("consumer_cpp: Cm = %.6f\n", out[0]);
  return out[0] > 0.0 ? 0 : 4;
}
