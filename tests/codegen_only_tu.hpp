// tests/codegen_only_tu.hpp -- the interface of tests/codegen_only_tu.cpp (plain types only, so
// that test_codegen.cpp need not see the generated headers' includes).
#pragma once

namespace codegen_only {

enum class GeneratedModel : int { tailless_model_2 = 0, synthetic_lift_moment = 1 };

// Resets at angle_rad[0] and steps samples 1..n-1 with the free functions; the outputs of
// sample k go to out[k * n_coefficients ...]. Returns the number of ok steps (n - 1 when all
// are), or < 0 if the model check or the reset failed.
int step_generated(GeneratedModel which, const double* angle_rad, const double* rate_radps, int n,
                   double dt_s, double airspeed_mps, double* out);

}  // namespace codegen_only
