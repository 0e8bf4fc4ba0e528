// runtime/src/mex/indicial_mex.cpp -- the runtime as a MEX function for Octave and MATLAB:
// load a coefficient file, reset, step one instance or a batch of instances of one model.
//
// Built by CMake with Octave's `mkoctfile --mex` (tests/CMakeLists.txt, tested under
// octave-cli in ctest); the same source builds for MATLAB (docs/integrators.md):
//   mex -R2017b -Iruntime/include -Ishared/include runtime/src/mex/indicial_mex.cpp \
//       runtime/src/indicial_c.cpp -output indicial_mex
// It uses the C interface (indicial/indicial.h) and the classic MEX API only (mxGetPr, no
// interleaved-complex calls), which both hosts provide.
//
// Usage (angles rad, rates rad/s, airspeed m/s, time s; N instances of one model):
//   h = indicial_mex('load', 'model.coef')          one instance
//   h = indicial_mex('load', 'model.coef', N)       N instances (a batch)
//   names = indicial_mex('outputs', h)              {'CL', 'Cm'}: the output columns
//   v_ref = indicial_mex('airspeed', h)             the model's reference airspeed
//   status = indicial_mex('reset', h, angle_rad, airspeed_mps)
//   [C, status] = indicial_mex('step', h, angle_rad, rate_radps, airspeed_mps, dt_s)
//   C = indicial_mex('evaluate', h, rate_radps, airspeed_mps)   outputs at the reset state
//   indicial_mex('free', h)                         (also freed when the MEX is cleared)
// angle, rate and airspeed are scalars (every instance the same) or N-vectors; C is N x
// outputs (row i: instance i). status is the indicial status (0 ok, 1 angle clamped);
// a refused reset or step (a negative status) is an error naming the status, and changes
// nothing.
//
// Warnings
// 1. Every argument is checked before anything is used: a wrong count, type (not a real
//    double, a char where a number belongs, complex, sparse), size or handle is an error
//    "indicial_mex: ..." (identifier indicial:*), never a crash. An error leaves this code
//    without running destructors in MATLAB, so scratch memory within a call comes from
//    mxMalloc / mxCalloc (freed by the host after the call, error or not), never from
//    std::vector or new; persistent memory (models, states) is malloc'd and owned by the table
//    before anything can raise.
// 2. Handles are small integers into a table in this MEX; a freed handle is refused. Clearing
//    the MEX (`clear indicial_mex`, `clear all`) frees every model.
#include <mex.h>

#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "indicial/indicial.h"

namespace {

// A loaded model and its N states (storage from malloc: persistent across MEX calls).
struct Stepper {
  void* model = nullptr;
  void* states = nullptr;
  std::size_t n = 0;
  std::size_t state_bytes = 0;
  int outputs = 0;
};

std::vector<Stepper*>& table() {
  static std::vector<Stepper*> t;
  return t;
}

void free_stepper(Stepper* s) {
  if (s == nullptr) return;
  std::free(s->model);
  std::free(s->states);
  std::free(s);
}

void free_all() {
  for (Stepper*& s : table()) {
    free_stepper(s);
    s = nullptr;
  }
}

[[noreturn]] void fail(const char* id, const char* fmt, ...) {
  char text[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(text, sizeof text, fmt, args);
  va_end(args);
  mexErrMsgIdAndTxt(id, "%s", text);
  std::abort();  // not reached: mexErrMsgIdAndTxt does not return
}

bool is_real_double(const mxArray* a) {
  return a != nullptr && mxIsDouble(a) && !mxIsComplex(a) && !mxIsSparse(a);
}

// A real double scalar argument (what: its name for the message).
double scalar(const mxArray* a, const char* what) {
  if (!is_real_double(a) || mxGetNumberOfElements(a) != 1)
    fail("indicial:badArgument", "%s must be a real double scalar", what);
  return mxGetPr(a)[0];
}

// A real double argument of 1 or n elements; *stride is 0 for a scalar (one value for all).
const double* vector_arg(const mxArray* a, std::size_t n, const char* what, std::size_t* stride) {
  if (!is_real_double(a)) fail("indicial:badArgument", "%s must be real double", what);
  const std::size_t k = mxGetNumberOfElements(a);
  if (k != 1 && k != n) {
    if (n == 1) fail("indicial:badSize", "%s has %zu elements; expected 1 (one instance)", what, k);
    fail("indicial:badSize", "%s has %zu elements; expected 1 or %zu (one per instance)", what, k, n);
  }
  *stride = k == 1 ? 0 : 1;
  return mxGetPr(a);
}

Stepper* stepper(const mxArray* a) {
  const double h = scalar(a, "the handle");
  if (!(h >= 1.0 && h <= static_cast<double>(table().size())) || h != std::floor(h) ||
      table()[static_cast<std::size_t>(h) - 1] == nullptr)
    fail("indicial:badHandle", "%g is not a handle of a loaded model (freed, or never returned by 'load')", h);
  return table()[static_cast<std::size_t>(h) - 1];
}

void* state_of(Stepper* s, std::size_t i) { return static_cast<char*>(s->states) + i * s->state_bytes; }

// The largest coefficient file read, as the FMU (fmu_slave.cpp): /dev/zero or a huge file would
// otherwise grow memory until the host dies.
constexpr std::size_t kMaxFileBytes = std::size_t(1) << 20;

// The file's bytes in mxMalloc memory (freed by the host after the call), or nullptr; a file
// above kMaxFileBytes is refused with an error.
char* read_file(const char* path, std::size_t* length) {
  *length = 0;
  std::FILE* f = std::fopen(path, "rb");
  if (f == nullptr) return nullptr;
  std::size_t capacity = 4096;
  char* text = static_cast<char*>(mxMalloc(capacity));
  for (std::size_t got; (got = std::fread(text + *length, 1, capacity - *length, f)) > 0;) {
    *length += got;
    if (*length > kMaxFileBytes) {
      std::fclose(f);
      fail("indicial:load", "%s: larger than 1 MB, not a coefficient file", path);
    }
    if (*length == capacity) {
      capacity *= 2;
      text = static_cast<char*>(mxRealloc(text, capacity));
    }
  }
  std::fclose(f);
  return text;
}

void cmd_load(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  if (nrhs < 2 || nrhs > 3 || nlhs > 1) fail("indicial:usage", "usage: h = indicial_mex('load', FILE[, N])");
  if (!mxIsChar(prhs[1])) fail("indicial:badArgument", "FILE must be a char array (the coefficient file's path)");
  double n = 1.0;
  if (nrhs == 3) n = scalar(prhs[2], "N");
  if (!(n >= 1.0 && n <= 1e7) || n != std::floor(n)) fail("indicial:badArgument", "N must be a whole number in 1..1e7");
  char* path = mxArrayToString(prhs[1]);
  if (path == nullptr) fail("indicial:badArgument", "FILE must be a char row (the coefficient file's path)");
  std::size_t length = 0;
  char* text = read_file(path, &length);
  if (text == nullptr || length == 0) fail("indicial:load", "cannot read %s (missing, empty or unreadable)", path);
  Stepper* s = static_cast<Stepper*>(std::calloc(1, sizeof(Stepper)));
  if (s == nullptr) fail("indicial:memory", "out of memory");
  s->model = std::malloc(indicial_model_bytes());
  char reason[256] = "";
  const int st = s->model == nullptr ? INDICIAL_ERROR_NULL_ARGUMENT
                                     : indicial_model_load(s->model, text, length, reason, sizeof reason);
  if (st != INDICIAL_OK) {
    free_stepper(s);
    fail("indicial:load", "%s: %s", path, reason);
  }
  s->n = static_cast<std::size_t>(n);
  s->outputs = indicial_model_outputs(s->model);
  s->state_bytes = indicial_state_bytes(s->model);
  s->states = std::calloc(s->n, s->state_bytes);  // zeroed: "not reset" until reset
  if (s->states == nullptr) {
    free_stepper(s);
    fail("indicial:memory", "out of memory for %g states", n);
  }
  table().push_back(s);
  plhs[0] = mxCreateDoubleScalar(static_cast<double>(table().size()));
}

void cmd_reset(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  if (nrhs != 4 || nlhs > 1) fail("indicial:usage", "usage: status = indicial_mex('reset', h, angle_rad, airspeed_mps)");
  Stepper* s = stepper(prhs[1]);
  std::size_t sa = 0, sv = 0;
  const double* angle = vector_arg(prhs[2], s->n, "angle_rad", &sa);
  const double* airspeed = vector_arg(prhs[3], s->n, "airspeed_mps", &sv);
  // Checked for every instance first: a refused reset changes no instance.
  for (std::size_t i = 0; i < s->n; ++i) {
    if (!std::isfinite(angle[i * sa]) || !std::isfinite(airspeed[i * sv]) || !(airspeed[i * sv] > 0.0))
      fail("indicial:reset", "instance %zu: angle %g rad, airspeed %g m/s: need finite values and airspeed > 0",
           i + 1, angle[i * sa], airspeed[i * sv]);
  }
  int worst = INDICIAL_OK;
  for (std::size_t i = 0; i < s->n; ++i) {
    const int st = indicial_reset(s->model, state_of(s, i), angle[i * sa], airspeed[i * sv]);
    if (st < 0) fail("indicial:reset", "instance %zu: reset refused (%s)", i + 1, indicial_status_string(st));
    if (st > worst) worst = st;
  }
  plhs[0] = mxCreateDoubleScalar(worst);
}

void cmd_step(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  if (nrhs != 6 || nlhs > 2)
    fail("indicial:usage", "usage: [C, status] = indicial_mex('step', h, angle_rad, rate_radps, airspeed_mps, dt_s)");
  Stepper* s = stepper(prhs[1]);
  std::size_t sa = 0, sr = 0, sv = 0;
  const double* angle = vector_arg(prhs[2], s->n, "angle_rad", &sa);
  const double* rate = vector_arg(prhs[3], s->n, "rate_radps", &sr);
  const double* airspeed = vector_arg(prhs[4], s->n, "airspeed_mps", &sv);
  const double dt_s = scalar(prhs[5], "dt_s");
  // The batch call wants one array per input: expand scalars.
  const std::size_t n_out = static_cast<std::size_t>(s->outputs);
  double* a = static_cast<double*>(mxCalloc(s->n, sizeof(double)));
  double* r = static_cast<double*>(mxCalloc(s->n, sizeof(double)));
  double* v = static_cast<double*>(mxCalloc(s->n, sizeof(double)));
  double* out = static_cast<double*>(mxCalloc(s->n * n_out, sizeof(double)));
  for (std::size_t i = 0; i < s->n; ++i) {
    a[i] = angle[i * sa];
    r[i] = rate[i * sr];
    v[i] = airspeed[i * sv];
  }
  // A refused instance leaves the others stepped (indicial.h): refuse before any step instead.
  for (std::size_t i = 0; i < s->n; ++i) {
    if (!std::isfinite(a[i]) || !std::isfinite(r[i]) || !std::isfinite(v[i]) || !std::isfinite(dt_s))
      fail("indicial:step", "instance %zu: an input is NaN or Inf", i + 1);
  }
  // All or nothing: the batch steps copies of the states, written back only if every instance
  // was stepped (a bad airspeed or a non-finite result in one lane changes no instance).
  const std::size_t state_total = s->n * s->state_bytes;
  void* copy = mxMalloc(state_total);
  std::memcpy(copy, s->states, state_total);
  const int st = s->n == 1 ? indicial_step(s->model, copy, a[0], r[0], v[0], dt_s, out)
                           : indicial_step_batch(s->model, copy, s->n, a, r, v, dt_s, out);
  if (st < 0) fail("indicial:step", "step refused: %s (dt_s = %g); no instance was stepped", indicial_status_string(st), dt_s);
  std::memcpy(s->states, copy, state_total);
  // out is row-major (instance, output); the MATLAB matrix is column-major N x outputs.
  mxArray* c = mxCreateDoubleMatrix(s->n, n_out, mxREAL);
  double* p = mxGetPr(c);
  for (std::size_t i = 0; i < s->n; ++i)
    for (std::size_t k = 0; k < n_out; ++k) p[k * s->n + i] = out[i * n_out + k];
  plhs[0] = c;
  if (nlhs > 1) plhs[1] = mxCreateDoubleScalar(st);
}

void cmd_evaluate(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  if (nrhs != 4 || nlhs > 1) fail("indicial:usage", "usage: C = indicial_mex('evaluate', h, rate_radps, airspeed_mps)");
  Stepper* s = stepper(prhs[1]);
  std::size_t sr = 0, sv = 0;
  const double* rate = vector_arg(prhs[2], s->n, "rate_radps", &sr);
  const double* airspeed = vector_arg(prhs[3], s->n, "airspeed_mps", &sv);
  const std::size_t n_out = static_cast<std::size_t>(s->outputs);
  mxArray* c = mxCreateDoubleMatrix(s->n, n_out, mxREAL);  // freed by the host on an error
  double* p = mxGetPr(c);
  for (std::size_t i = 0; i < s->n; ++i) {
    double out[8] = {};  // indicial_model_outputs is 1..3
    const int st = indicial_evaluate(s->model, state_of(s, i), rate[i * sr], airspeed[i * sv], out);
    if (st < 0) fail("indicial:evaluate", "instance %zu: %s", i + 1, indicial_status_string(st));
    for (std::size_t k = 0; k < n_out; ++k) p[k * s->n + i] = out[k];
  }
  plhs[0] = c;
}

void cmd_outputs(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  if (nrhs != 2 || nlhs > 1) fail("indicial:usage", "usage: names = indicial_mex('outputs', h)");
  Stepper* s = stepper(prhs[1]);
  mxArray* names = mxCreateCellMatrix(1, static_cast<std::size_t>(s->outputs));
  for (int k = 0; k < s->outputs; ++k)
    mxSetCell(names, static_cast<std::size_t>(k), mxCreateString(indicial_model_output_name(s->model, k)));
  plhs[0] = names;
}

void cmd_airspeed(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  if (nrhs != 2 || nlhs > 1) fail("indicial:usage", "usage: v_ref = indicial_mex('airspeed', h)");
  plhs[0] = mxCreateDoubleScalar(indicial_model_reference_airspeed_mps(stepper(prhs[1])->model));
}

void cmd_free(int nlhs, int nrhs, const mxArray* prhs[]) {
  if (nrhs != 2 || nlhs > 0) fail("indicial:usage", "usage: indicial_mex('free', h)");
  Stepper* s = stepper(prhs[1]);
  table()[static_cast<std::size_t>(mxGetPr(prhs[1])[0]) - 1] = nullptr;
  free_stepper(s);
}

}  // namespace

extern "C" void mexFunction(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  static bool registered = false;
  if (!registered) {
    mexAtExit(free_all);
    registered = true;
  }
  if (nrhs < 1 || !mxIsChar(prhs[0]))
    fail("indicial:usage", "the first argument is a command: 'load', 'outputs', 'airspeed', 'reset', 'step', "
                           "'evaluate' or 'free'");
  char command[16] = "";
  if (mxGetString(prhs[0], command, sizeof command) != 0) fail("indicial:usage", "unknown command");
  if (std::strcmp(command, "load") == 0) return cmd_load(nlhs, plhs, nrhs, prhs);
  if (std::strcmp(command, "reset") == 0) return cmd_reset(nlhs, plhs, nrhs, prhs);
  if (std::strcmp(command, "step") == 0) return cmd_step(nlhs, plhs, nrhs, prhs);
  if (std::strcmp(command, "evaluate") == 0) return cmd_evaluate(nlhs, plhs, nrhs, prhs);
  if (std::strcmp(command, "outputs") == 0) return cmd_outputs(nlhs, plhs, nrhs, prhs);
  if (std::strcmp(command, "airspeed") == 0) return cmd_airspeed(nlhs, plhs, nrhs, prhs);
  if (std::strcmp(command, "free") == 0) return cmd_free(nlhs, nrhs, prhs);
  fail("indicial:usage", "unknown command '%s' (load, outputs, airspeed, reset, step, evaluate, free)", command);
}
