// diagnose_polar_model.hpp -- a model configuration with a lift polar through stall, for the
// tests of which diagnose candidates are offered (test_diagnose_starts, test_diagnose_registry).
#pragma once

#include <cmath>

#include "indicial/fitter/experiment.hpp"

namespace indicial::testing {

// -0.3..0.3 rad, a thin-airfoil line that saturates: the dynamic-stall candidates are offered.
inline ModelConfig model_with_polar() {
  ModelConfig model;
  for (int i = -6; i <= 6; ++i) {
    model.stall.polar_x_rad.push_back(0.05 * i);
    model.stall.polar_lift.push_back(2.0 * M_PI * 0.05 * i / (1.0 + 4.0 * 0.0025 * i * i));
  }
  return model;
}

}  // namespace indicial::testing
