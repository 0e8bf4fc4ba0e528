// tests/codegen_only_tu.cpp -- a translation unit that uses only `indicial codegen` output and
// the step header, as a codegen-only firmware would. Compiled into test_codegen WITHOUT the
// tests' precompiled header (tests/CMakeLists.txt), so the guards below see exactly what the
// generated headers include: no coefficient-file parser, no <charconv>.
#include "synthetic_lift_moment.hpp"
#include "tailless_model_2.hpp"

#ifdef INDICIAL_COEF_FILE_HPP_INCLUDED
#error "a codegen-only translation unit includes the coefficient-file parser (coef_file.hpp)"
#endif
#if defined(_GLIBCXX_CHARCONV) || defined(_LIBCPP_CHARCONV)
#error "a codegen-only translation unit includes <charconv>"
#endif

#include "codegen_only_tu.hpp"

static_assert(sizeof(indicial::State<double, indicial::DefaultCapacity>) <= 256,
              "issue 15: a per-instance state without delay ring of at most 256 bytes");
static_assert(sizeof(indicial::FamilyState<double, indicial::DefaultCapacity>) <= 256,
              "issue 22: C_L + C_m with every dynamic-stall family in at most 256 bytes");

namespace codegen_only {

int step_generated(GeneratedModel which, const double* angle_rad, const double* rate_radps, int n,
                   double dt_s, double airspeed_mps, double* out) {
  // The constexpr models are used in place: a reference, never a copy.
  const indicial::RuntimeModel<double, indicial::DefaultCapacity>& m =
      which == GeneratedModel::tailless_model_2 ? indicial_generated::tailless_model_2
                                                : indicial_generated::synthetic_lift_moment;
  if (indicial::check_runtime_model(m) != indicial::LoadStatus::ok) return -1;
  indicial::State<double, indicial::DefaultCapacity> state;
  if (indicial::reset(m, state, angle_rad[0], airspeed_mps) != indicial::StepStatus::ok) return -2;
  const int count = m.set.n_coefficients;
  int done = 0;
  for (int k = 1; k < n; ++k) {
    const indicial::MotionInput in{angle_rad[k], rate_radps[k], airspeed_mps};
    if (indicial::step(m, state, in, dt_s, out + count * k) != indicial::StepStatus::ok) break;
    ++done;
  }
  return done;
}

}  // namespace codegen_only
