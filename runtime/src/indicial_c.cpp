// runtime/src/indicial_c.cpp -- the C interface (indicial/indicial.h) over the C++ runtime:
// RuntimeModel<double, DefaultCapacity> in caller storage, State, FamilyState or DelayedState
// per instance (by the model's delay and dynamic-stall family use), statuses mapped to the header's numbers. Compiled with
// -fno-exceptions -fno-rtti; no heap.
#include "indicial/indicial.h"

#include <cmath>
#include <cstdint>
#include <cstdio>

#include "indicial/batch.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"

namespace {

using Cap = indicial::DefaultCapacity;
using Model = indicial::RuntimeModel<double, Cap>;
using PlainState = indicial::State<double, Cap>;
using FamState = indicial::FamilyState<double, Cap>;
using RingState = indicial::DelayedState<double, Cap>;

// What the caller's model storage holds: a marker that a load succeeded, then the model.
constexpr std::uint32_t loaded_marker = 0x1d1c1a11u;
struct CModel {
  std::uint32_t marker;
  Model model;
};

bool aligned(const void* p) {
  return reinterpret_cast<std::uintptr_t>(p) % alignof(double) == 0;
}

// The loaded model, or nullptr (with *status set) if the storage holds none.
const Model* loaded(const void* storage, int* status) {
  if (storage == nullptr) {
    *status = INDICIAL_ERROR_NULL_ARGUMENT;
    return nullptr;
  }
  if (!aligned(storage)) {
    *status = INDICIAL_ERROR_MISALIGNED;
    return nullptr;
  }
  const CModel* c = static_cast<const CModel*>(storage);
  if (c->marker != loaded_marker) {
    *status = INDICIAL_ERROR_NOT_LOADED;
    return nullptr;
  }
  return &c->model;
}

int c_status(indicial::StepStatus s) {
  if (s == indicial::StepStatus::ok) return INDICIAL_OK;
  if (s == indicial::StepStatus::angle_clamped) return INDICIAL_ANGLE_CLAMPED;
  return -static_cast<int>(s);
}

int c_status(indicial::LoadStatus s) {
  return s == indicial::LoadStatus::ok ? INDICIAL_OK : -(100 + static_cast<int>(s));
}

void write_error(char* error, std::size_t length, const indicial::ParseDiagnostic& d,
                 indicial::LoadStatus s) {
  if (error == nullptr || length == 0) return;
  std::snprintf(error, length, "line %zu: %s (%s)", d.line, d.reason, indicial::to_string(s));
}

}  // namespace

extern "C" {

size_t indicial_model_bytes(void) { return sizeof(CModel); }

int indicial_model_load(void* model, const char* text, size_t length, char* error,
                        size_t error_length) {
  indicial::ParseDiagnostic diag;
  if (model == nullptr) {
    diag.reason = "no model storage given";
    write_error(error, error_length, diag, indicial::LoadStatus::null_argument);
    return INDICIAL_ERROR_NULL_ARGUMENT;
  }
  if (!aligned(model)) {
    diag.reason = "model storage is not aligned for a double";
    write_error(error, error_length, diag, indicial::LoadStatus::null_argument);
    return INDICIAL_ERROR_MISALIGNED;
  }
  CModel* c = static_cast<CModel*>(model);
  // A refused load writes nothing (load_runtime_model writes *out only on success).
  const indicial::LoadStatus s = indicial::load_runtime_model(text, length, &c->model, &diag);
  if (s != indicial::LoadStatus::ok) {
    write_error(error, error_length, diag, s);
    return c_status(s);
  }
  c->marker = loaded_marker;
  if (error != nullptr && error_length > 0) error[0] = '\0';
  return INDICIAL_OK;
}

int indicial_model_outputs(const void* model) {
  int status = 0;
  const Model* m = loaded(model, &status);
  return m == nullptr ? status : m->set.n_coefficients;
}

const char* indicial_model_output_name(const void* model, int i) {
  int status = 0;
  const Model* m = loaded(model, &status);
  if (m == nullptr || i < 0 || i >= m->set.n_coefficients) return nullptr;
  return m->set.coefficients[i].name;
}

double indicial_model_reference_airspeed_mps(const void* model) {
  int status = 0;
  const Model* m = loaded(model, &status);
  return m == nullptr ? 0.0 : static_cast<double>(m->set.airspeed_mps);
}

size_t indicial_state_bytes(const void* model) {
  int status = 0;
  const Model* m = loaded(model, &status);
  if (m == nullptr) return 0;
  if (m->delay != indicial::DelayUse::none) return sizeof(RingState);
  return m->stall != indicial::StallUse::none ? sizeof(FamState) : sizeof(PlainState);
}

int indicial_reset(const void* model, void* state, double angle_rad, double airspeed_mps) {
  int status = 0;
  const Model* m = loaded(model, &status);
  if (m == nullptr) return status;
  if (state == nullptr) return INDICIAL_ERROR_NULL_ARGUMENT;
  if (!aligned(state)) return INDICIAL_ERROR_MISALIGNED;
  // A refused reset changes nothing (reset() checks before it writes).
  if (m->delay != indicial::DelayUse::none)
    return c_status(indicial::reset(*m, *static_cast<RingState*>(state), angle_rad, airspeed_mps));
  if (m->stall != indicial::StallUse::none)
    return c_status(indicial::reset(*m, *static_cast<FamState*>(state), angle_rad, airspeed_mps));
  return c_status(indicial::reset(*m, *static_cast<PlainState*>(state), angle_rad, airspeed_mps));
}

int indicial_step(const void* model, void* state, double angle_rad, double rate_radps,
                  double airspeed_mps, double dt_s, double* out) {
  int status = 0;
  const Model* m = loaded(model, &status);
  if (m == nullptr) return status;
  if (state == nullptr) return INDICIAL_ERROR_NULL_ARGUMENT;
  if (!aligned(state)) return INDICIAL_ERROR_MISALIGNED;
  const indicial::MotionInput in{angle_rad, rate_radps, airspeed_mps};
  if (m->delay != indicial::DelayUse::none)
    return c_status(indicial::step(*m, *static_cast<RingState*>(state), in, dt_s, out));
  if (m->stall != indicial::StallUse::none)
    return c_status(indicial::step(*m, *static_cast<FamState*>(state), in, dt_s, out));
  return c_status(indicial::step(*m, *static_cast<PlainState*>(state), in, dt_s, out));
}

int indicial_evaluate(const void* model, const void* state, double rate_radps,
                      double airspeed_mps, double* out) {
  int status = 0;
  const Model* m = loaded(model, &status);
  if (m == nullptr) return status;
  if (state == nullptr) return INDICIAL_ERROR_NULL_ARGUMENT;
  if (!aligned(state)) return INDICIAL_ERROR_MISALIGNED;
  // A model with dynamic-stall families has a FamilyState (or a DelayedState, derived from it).
  if (m->stall != indicial::StallUse::none)
    return c_status(indicial::evaluate(*m, *static_cast<const FamState*>(state), rate_radps, airspeed_mps, out));
  return c_status(indicial::evaluate(*m, *static_cast<const PlainState*>(state), rate_radps, airspeed_mps, out));
}

int indicial_step_batch(const void* model, void* states, size_t n, const double* angle_rad,
                        const double* rate_radps, const double* airspeed_mps, double dt_s,
                        double* out) {
  int status = 0;
  const Model* m = loaded(model, &status);
  if (m == nullptr) return status;
  if (n > 0 && (states == nullptr || angle_rad == nullptr || rate_radps == nullptr ||
                airspeed_mps == nullptr))
    return INDICIAL_ERROR_NULL_ARGUMENT;
  if (states != nullptr && !aligned(states)) return INDICIAL_ERROR_MISALIGNED;
  if (m->delay != indicial::DelayUse::none)
    return c_status(indicial::step_batch(*m, static_cast<RingState*>(states), n, angle_rad,
                                         rate_radps, airspeed_mps, dt_s, out));
  if (m->stall != indicial::StallUse::none)
    return c_status(indicial::step_batch(*m, static_cast<FamState*>(states), n, angle_rad,
                                         rate_radps, airspeed_mps, dt_s, out));
  return c_status(indicial::step_batch(*m, static_cast<PlainState*>(states), n, angle_rad,
                                       rate_radps, airspeed_mps, dt_s, out));
}

const char* indicial_status_string(int status) {
  if (status == INDICIAL_OK) return "ok";
  if (status == INDICIAL_ANGLE_CLAMPED) return "angle_clamped";
  if (status == INDICIAL_ERROR_MISALIGNED) return "misaligned_storage";
  if (status == INDICIAL_ERROR_STORAGE_TOO_SMALL) return "storage_too_small";
  if (status <= -101 && status >= -(100 + static_cast<int>(indicial::LoadStatus::unstable_lag)))
    return indicial::to_string(static_cast<indicial::LoadStatus>(-status - 100));
  if (status <= -2 && status >= -static_cast<int>(indicial::StepStatus::families_need_state))
    return indicial::to_string(static_cast<indicial::StepStatus>(-status));
  return "unknown_status";
}

// ---- Typed handles: the same storage, the untyped functions above do the work. -----------
// The handle types are never defined: a handle is the storage's address, converted back to
// void* here (a pointer to an incomplete struct type round-trips through void*).

// The project's version, given by CMake (INDICIAL_VERSION_STRING, the root project(VERSION));
// a build that compiles this file by hand without it reports "unknown".
// mkoctfile (the MEX build) runs the compiler through a shell that drops quotes, so it passes
// the bare token INDICIAL_VERSION_TOKEN=0.1.0 (a valid preprocessing number) to be stringized.
#if !defined(INDICIAL_VERSION_STRING) && defined(INDICIAL_VERSION_TOKEN)
#define INDICIAL_STRINGIZE_(x) #x
#define INDICIAL_STRINGIZE(x) INDICIAL_STRINGIZE_(x)
#define INDICIAL_VERSION_STRING INDICIAL_STRINGIZE(INDICIAL_VERSION_TOKEN)
#endif
#ifndef INDICIAL_VERSION_STRING
#define INDICIAL_VERSION_STRING "unknown"
#endif
const char* indicial_version(void) { return INDICIAL_VERSION_STRING; }

int indicial_model_init(void* storage, size_t storage_bytes, const char* text, size_t length,
                        char* error, size_t error_length, indicial_model** model) {
  if (model != nullptr) *model = nullptr;
  indicial::ParseDiagnostic diag;
  if (model == nullptr) {
    diag.reason = "no handle to write given";
    write_error(error, error_length, diag, indicial::LoadStatus::null_argument);
    return INDICIAL_ERROR_NULL_ARGUMENT;
  }
  if (storage != nullptr && storage_bytes < sizeof(CModel)) {
    diag.reason = "model storage smaller than indicial_model_bytes()";
    write_error(error, error_length, diag, indicial::LoadStatus::null_argument);
    return INDICIAL_ERROR_STORAGE_TOO_SMALL;
  }
  const int s = indicial_model_load(storage, text, length, error, error_length);
  if (s == INDICIAL_OK) *model = static_cast<indicial_model*>(storage);
  return s;
}

int indicial_model_output_count(const indicial_model* model) {
  return indicial_model_outputs(model);
}

const char* indicial_model_output_label(const indicial_model* model, int i) {
  return indicial_model_output_name(model, i);
}

size_t indicial_model_state_bytes(const indicial_model* model) {
  return indicial_state_bytes(model);
}

double indicial_model_airspeed_mps(const indicial_model* model) {
  return indicial_model_reference_airspeed_mps(model);
}

int indicial_state_init(const indicial_model* model, void* storage, size_t storage_bytes,
                        double angle_rad, double airspeed_mps, indicial_state** state) {
  if (state == nullptr) return INDICIAL_ERROR_NULL_ARGUMENT;
  *state = nullptr;
  int status = 0;
  if (loaded(model, &status) == nullptr) return status;
  if (storage != nullptr && storage_bytes < indicial_state_bytes(model))
    return INDICIAL_ERROR_STORAGE_TOO_SMALL;
  const int s = indicial_reset(model, storage, angle_rad, airspeed_mps);
  if (s >= 0) *state = static_cast<indicial_state*>(storage);
  return s;
}

int indicial_state_reset(const indicial_model* model, indicial_state* state, double angle_rad,
                         double airspeed_mps) {
  return indicial_reset(model, state, angle_rad, airspeed_mps);
}

int indicial_state_step(const indicial_model* model, indicial_state* state, double angle_rad,
                        double rate_radps, double airspeed_mps, double dt_s, double* out) {
  return indicial_step(model, state, angle_rad, rate_radps, airspeed_mps, dt_s, out);
}

int indicial_state_evaluate(const indicial_model* model, const indicial_state* state,
                            double rate_radps, double airspeed_mps, double* out) {
  return indicial_evaluate(model, state, rate_radps, airspeed_mps, out);
}

int indicial_state_step_batch(const indicial_model* model, indicial_state* states, size_t n,
                              const double* angle_rad, const double* rate_radps,
                              const double* airspeed_mps, double dt_s, double* out) {
  return indicial_step_batch(model, states, n, angle_rad, rate_radps, airspeed_mps, dt_s, out);
}

}  // extern "C"
