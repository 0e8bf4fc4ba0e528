// runtime/src/fmu/fmu_slave.cpp -- the shared library inside every FMU that `indicial fmu`
// writes: an FMI 2.0 co-simulation slave over the C interface (indicial/indicial.h).
//
// What it is
// ----------
// One prebuilt library for every model: `indicial fmu` copies it into the package as
// binaries/linux64/<modelIdentifier>.so next to resources/model.coef and the
// modelDescription.xml it writes for that model. fmi2Instantiate reads and validates the
// coefficient file (indicial_model_load: the same parser and checks as every other reader),
// checks that it is the file the description was written for (the GUID, fmu_layout.hpp),
// and refuses with a logged reason and NULL otherwise.
//
// Semantics (docs/integrators.md)
// -------------------------------
// - ExitInitializationMode: the state is reset to the steady state at the parameters
//   initial angle / initial airspeed; the outputs at the start time are the model there with
//   the rate and airspeed inputs (indicial_evaluate): what `indicial predict` writes at its
//   first sample.
// - fmi2DoStep(t, h): the inputs set before it are the motion at the END of the step (the
//   runtime's "step to this sample"); the outputs become the coefficients at t + h. Outputs
//   therefore do not depend on inputs set at the same communication point (no direct
//   feedthrough: the description declares dependencies=""), so a master may close a loop
//   through the FMU without an algebraic loop. h may vary from step to step; a step longer
//   than the runtime's 1 s limit is done as ceil(h / 1 s) equal sub-steps with the inputs held.
//   A step above kMaxCommunicationStepS (1e6 s, a million sub-steps, about a second of work) is
//   refused: a step in ms passed as s, or a huge h, would otherwise freeze the importer.
// - Communication points: t must be the end of the previous step to within a millionth of a
//   step plus 64 ulp of t (masters that compute t = t0 + i h and those that sum h both pass);
//   the next step starts at the master's t, so nothing accumulates in the FMU.
// - Errors: every refused call returns fmi2Error with a logged reason (category
//   logStatusError) and changes nothing (except that a DoStep the runtime refuses sets
//   step_status to the runtime's negative status, so a master can read why); as FMI 2.0 prescribes, the instance is then in its
//   error state, where only fmi2Get*, fmi2Reset and fmi2FreeInstance are accepted. Calls on a
//   NULL, freed or foreign component return fmi2Error (live instances are kept in a registry,
//   so such a pointer is never dereferenced).
//
// Warnings
// 1. Compiled with -fno-exceptions -fno-rtti and no operator new: memory comes from the
//    importer's allocateMemory / freeMemory only, as FMI 2.0 asks.
// 2. indicial_model_load keeps about 40 KB on the stack (indicial.h warning 4): importers'
//    threads have far more, but fmi2Instantiate must not be called from an interrupt.
// 3. A clamped angle (status 1) is not an error: the step is done, step_status says 1, and a
//    warning is logged only when debug logging is on (it can happen at every step).
#include <pthread.h>

#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <new>

#include "fmi2.h"
#include "fmu_layout.hpp"
#include "indicial/indicial.h"

namespace {

namespace fmu = indicial::fmu;

constexpr int kMaxOutputs = 8;
constexpr std::uint32_t kLiveMagic = 0x1f3a2b4cu;
constexpr long kMaxModelBytes = 1 << 20;  // a coefficient file is a few KB

enum class Phase { instantiated, initialization, step_complete, terminated, error };

const char* phase_name(Phase p) {
  switch (p) {
    case Phase::instantiated: return "instantiated";
    case Phase::initialization: return "initialization mode";
    case Phase::step_complete: return "step complete";
    case Phase::terminated: return "terminated";
    case Phase::error: return "error (after an fmi2Error: fmi2Reset or fmi2FreeInstance)";
  }
  return "unknown";
}

// Which phases accept a call (a bit per Phase).
constexpr unsigned bit(Phase p) { return 1u << static_cast<unsigned>(p); }
constexpr unsigned kAnyPhase = 0x1fu;

struct Inputs {
  double angle_rad = 0.0;
  double rate_radps = 0.0;
  double airspeed_mps = 1.0;
  double initial_angle_rad = 0.0;
  double initial_airspeed_mps = 1.0;
};

struct Instance {
  std::uint32_t magic = 0;
  Instance* next_live = nullptr;
  fmi2CallbackLogger logger = nullptr;
  fmi2CallbackAllocateMemory allocate = nullptr;
  fmi2CallbackFreeMemory free_memory = nullptr;
  fmi2ComponentEnvironment environment = nullptr;
  char* name = nullptr;
  bool logging_on = false;
  Phase phase = Phase::instantiated;
  double start_time_s = 0.0;
  bool stop_time_defined = false;
  double stop_time_s = 0.0;
  double time_s = 0.0;
  double last_step_s = 0.0;
  Inputs in;
  Inputs start;  // the start values of modelDescription.xml (fmi2Reset returns to them)
  int n_outputs = 0;
  double out[kMaxOutputs] = {};
  int step_status = 0;
  void* model = nullptr;
  void* state = nullptr;
  void* scratch = nullptr;  // a copy of the state: a failed sub-step restores it
  std::size_t state_bytes = 0;
};

// ---- the registry of live instances: a component is dereferenced only if it is in it ----
pthread_mutex_t registry_lock = PTHREAD_MUTEX_INITIALIZER;
Instance* live_head = nullptr;

void register_instance(Instance* inst) {
  pthread_mutex_lock(&registry_lock);
  inst->next_live = live_head;
  live_head = inst;
  pthread_mutex_unlock(&registry_lock);
}

bool unregister_instance(Instance* inst) {
  pthread_mutex_lock(&registry_lock);
  bool found = false;
  for (Instance** p = &live_head; *p != nullptr; p = &(*p)->next_live) {
    if (*p == inst) {
      *p = inst->next_live;
      found = true;
      break;
    }
  }
  pthread_mutex_unlock(&registry_lock);
  return found;
}

Instance* live(fmi2Component c) {
  if (c == nullptr) return nullptr;
  pthread_mutex_lock(&registry_lock);
  Instance* found = nullptr;
  for (Instance* p = live_head; p != nullptr; p = p->next_live)
    if (p == c) found = p;
  pthread_mutex_unlock(&registry_lock);
  return found != nullptr && found->magic == kLiveMagic ? found : nullptr;
}

// ---- logging --------------------------------------------------------------------------
// The logger's message is a printf format: '%' is doubled so that a file name or reason is
// printed as it is, whichever way the importer formats.
void log_to(fmi2CallbackLogger logger, fmi2ComponentEnvironment env, const char* name, fmi2Status s,
            const char* category, const char* fmt, va_list args) {
  if (logger == nullptr) return;
  char text[512];
  std::vsnprintf(text, sizeof text, fmt, args);
  char escaped[1024];
  std::size_t j = 0;
  for (std::size_t i = 0; text[i] != '\0' && j + 2 < sizeof escaped; ++i) {
    if (text[i] == '%') escaped[j++] = '%';
    escaped[j++] = text[i];
  }
  escaped[j] = '\0';
  logger(env, name != nullptr ? name : "", s, category, escaped);
}

fmi2Status fail(Instance* inst, const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  log_to(inst->logger, inst->environment, inst->name, fmi2Error, "logStatusError", fmt, args);
  va_end(args);
  inst->phase = Phase::error;
  return fmi2Error;
}

void warn(Instance* inst, const char* fmt, ...) {
  if (!inst->logging_on) return;
  va_list args;
  va_start(args, fmt);
  log_to(inst->logger, inst->environment, inst->name, fmi2Warning, "logStatusWarning", fmt, args);
  va_end(args);
}

// The instance behind c if the call is allowed in its phase; otherwise logs and returns nullptr
// (*status is then fmi2Error).
Instance* checked(fmi2Component c, const char* function, unsigned allowed, fmi2Status* status) {
  *status = fmi2Error;
  Instance* inst = live(c);
  if (inst == nullptr) return nullptr;  // NULL, freed or foreign: nothing to log to
  if ((allowed & bit(inst->phase)) == 0) {
    fail(inst, "%s: not allowed in phase %s", function, phase_name(inst->phase));
    return nullptr;
  }
  *status = fmi2OK;
  return inst;
}

// ---- instantiation -----------------------------------------------------------------------
int hex_value(char ch) {
  if (ch >= '0' && ch <= '9') return ch - '0';
  if (ch >= 'a' && ch <= 'f') return ch - 'a' + 10;
  if (ch >= 'A' && ch <= 'F') return ch - 'A' + 10;
  return -1;
}

// The local path of a file: URI (file:///p, file:/p, file://localhost/p; %XX decoded) plus
// "/" + file. False if the URI is not a local file URI or the path does not fit.
bool resource_file_path(const char* uri, const char* file, char* out, std::size_t out_size) {
  if (uri == nullptr || std::strncmp(uri, "file:", 5) != 0) return false;
  const char* p = uri + 5;
  if (std::strncmp(p, "//localhost/", 12) == 0) p += 11;
  else if (std::strncmp(p, "///", 3) == 0) p += 2;
  else if (std::strncmp(p, "//", 2) == 0) return false;  // another host
  if (*p != '/') return false;
  std::size_t n = 0;
  for (; *p != '\0'; ++p) {
    char ch = *p;
    if (ch == '%') {
      const int hi = hex_value(p[1]);
      const int lo = hi < 0 ? -1 : hex_value(p[2]);
      if (lo < 0) return false;
      ch = static_cast<char>(hi * 16 + lo);
      p += 2;
    }
    if (n + 1 >= out_size) return false;
    out[n++] = ch;
  }
  if (n == 0 || out[n - 1] != '/') {
    if (n + 1 >= out_size) return false;
    out[n++] = '/';
  }
  const std::size_t fn = std::strlen(file);
  if (n + fn + 1 > out_size) return false;
  std::memcpy(out + n, file, fn + 1);
  return true;
}

void* allocate(Instance* inst, std::size_t bytes) { return inst->allocate(1, bytes); }

void release(Instance* inst, void* p) {
  if (p != nullptr) inst->free_memory(p);
}

void free_parts(Instance* inst) {
  release(inst, inst->model);
  release(inst, inst->state);
  release(inst, inst->scratch);
  release(inst, inst->name);
}

// Reads the whole file into memory from the importer's allocator; nullptr (logged) on error.
char* read_model_file(Instance* inst, const char* path, std::size_t* length) {
  std::FILE* f = std::fopen(path, "rb");
  if (f == nullptr) {
    fail(inst, "fmi2Instantiate: cannot open %s (the FMU's resources/%s)", path, fmu::kModelResource);
    return nullptr;
  }
  long size = -1;
  if (std::fseek(f, 0, SEEK_END) == 0) size = std::ftell(f);
  if (size < 0 || size > kMaxModelBytes || std::fseek(f, 0, SEEK_SET) != 0) {
    std::fclose(f);
    fail(inst, "fmi2Instantiate: %s: unreadable or larger than %ld bytes", path, kMaxModelBytes);
    return nullptr;
  }
  char* text = static_cast<char*>(allocate(inst, static_cast<std::size_t>(size) + 1));
  if (text == nullptr) {
    std::fclose(f);
    fail(inst, "fmi2Instantiate: out of memory reading %s", path);
    return nullptr;
  }
  *length = std::fread(text, 1, static_cast<std::size_t>(size), f);
  const bool short_read = *length != static_cast<std::size_t>(size);
  std::fclose(f);
  if (short_read) {
    release(inst, text);
    fail(inst, "fmi2Instantiate: %s: short read", path);
    return nullptr;
  }
  return text;
}

// Loads resources/model.coef into inst->model and sizes the states; false (logged) on error.
bool load_model(Instance* inst, const char* guid, const char* resource_location) {
  char path[4096];
  if (!resource_file_path(resource_location, fmu::kModelResource, path, sizeof path))
    return fail(inst, "fmi2Instantiate: fmuResourceLocation '%s' is not a local file: URI",
                resource_location != nullptr ? resource_location : "(null)"), false;
  std::size_t length = 0;
  char* text = read_model_file(inst, path, &length);
  if (text == nullptr) return false;
  char expected[fmu::kGuidChars];
  fmu::model_guid(text, length, expected);
  if (std::strcmp(expected, guid) != 0) {
    release(inst, text);
    return fail(inst,
                "fmi2Instantiate: %s is not the model this FMU was made for (its GUID is %s, the "
                "modelDescription.xml says %s): the package is damaged or its parts were swapped",
                path, expected, guid), false;
  }
  inst->model = allocate(inst, indicial_model_bytes());
  char reason[256] = "";
  const int s = inst->model == nullptr ? INDICIAL_ERROR_NULL_ARGUMENT
                                       : indicial_model_load(inst->model, text, length, reason, sizeof reason);
  release(inst, text);
  if (s != INDICIAL_OK) return fail(inst, "fmi2Instantiate: %s: %s", path, reason), false;
  inst->n_outputs = indicial_model_outputs(inst->model);
  if (inst->n_outputs < 1 || inst->n_outputs > kMaxOutputs)
    return fail(inst, "fmi2Instantiate: %s: %d outputs", path, inst->n_outputs), false;
  inst->state_bytes = indicial_state_bytes(inst->model);
  inst->state = allocate(inst, inst->state_bytes);
  inst->scratch = allocate(inst, inst->state_bytes);
  if (inst->state == nullptr || inst->scratch == nullptr)
    return fail(inst, "fmi2Instantiate: out of memory for the state"), false;
  const double v_ref = indicial_model_reference_airspeed_mps(inst->model);
  inst->start.airspeed_mps = v_ref;
  inst->start.initial_airspeed_mps = v_ref;
  inst->in = inst->start;
  return true;
}

void reset_values(Instance* inst) {
  inst->in = inst->start;
  inst->phase = Phase::instantiated;
  inst->start_time_s = inst->time_s = inst->last_step_s = 0.0;
  inst->stop_time_defined = false;
  inst->stop_time_s = 0.0;
  for (double& o : inst->out) o = 0.0;
  inst->step_status = 0;
}

// ---- variables ---------------------------------------------------------------------------
bool is_coefficient(const Instance* inst, fmi2ValueReference vr) {
  return vr >= fmu::vr_first_coefficient &&
         vr < fmu::vr_first_coefficient + static_cast<unsigned>(inst->n_outputs);
}

// The Real a value reference names (inputs and parameters), or nullptr.
double* settable_real(Instance* inst, fmi2ValueReference vr) {
  switch (vr) {
    case fmu::vr_angle_rad: return &inst->in.angle_rad;
    case fmu::vr_rate_radps: return &inst->in.rate_radps;
    case fmu::vr_airspeed_mps: return &inst->in.airspeed_mps;
    case fmu::vr_initial_angle_rad: return &inst->in.initial_angle_rad;
    case fmu::vr_initial_airspeed_mps: return &inst->in.initial_airspeed_mps;
    default: return nullptr;
  }
}

bool is_parameter(fmi2ValueReference vr) {
  return vr == fmu::vr_initial_angle_rad || vr == fmu::vr_initial_airspeed_mps;
}

bool is_airspeed(fmi2ValueReference vr) {
  return vr == fmu::vr_airspeed_mps || vr == fmu::vr_initial_airspeed_mps;
}

// Resets the state at the initial angle and airspeed and sets the outputs there.
fmi2Status initialize_outputs(Instance* inst, const char* function) {
  const int r = indicial_reset(inst->model, inst->state, inst->in.initial_angle_rad,
                               inst->in.initial_airspeed_mps);
  if (r < 0) return fail(inst, "%s: reset refused: %s", function, indicial_status_string(r));
  double out[kMaxOutputs] = {};
  const int e = indicial_evaluate(inst->model, inst->state, inst->in.rate_radps, inst->in.airspeed_mps, out);
  if (e < 0) return fail(inst, "%s: the outputs at the start are refused: %s", function, indicial_status_string(e));
  for (int i = 0; i < inst->n_outputs; ++i) inst->out[i] = out[i];
  inst->step_status = r;
  return fmi2OK;
}

// ---- stepping ----------------------------------------------------------------------------
// The largest distance between a communication point and the FMU's time that is rounding.
// The longest communication step accepted: 1e6 sub-steps of at most 1 s each.
constexpr double kMaxCommunicationStepS = 1e6;

double communication_tolerance_s(double t_s, double cp_s, double h_s, double last_h_s) {
  const double scale = std::fmax(std::fabs(t_s), std::fabs(cp_s));
  const double ulp = std::nextafter(scale, HUGE_VAL) - scale;
  return 1e-6 * std::fmax(h_s, last_h_s) + 64.0 * ulp;
}

// Steps the state over h_s with the inputs held (ceil(h / 1 s) sub-steps); on a refused
// sub-step the state is restored and the status returned.
// The caller has checked 0 < h_s <= kMaxCommunicationStepS, so n fits an integer counter.
int step_held(Instance* inst, double h_s, double* out) {
  const double max_dt_s = 1.0;
  const long n = static_cast<long>(std::ceil(h_s / max_dt_s));
  const double dt_s = n > 1 ? h_s / static_cast<double>(n) : h_s;
  std::memcpy(inst->scratch, inst->state, inst->state_bytes);
  int worst = INDICIAL_OK;
  for (long i = 0; i < n; ++i) {
    const int s = indicial_step(inst->model, inst->state, inst->in.angle_rad, inst->in.rate_radps,
                                inst->in.airspeed_mps, dt_s, out);
    if (s < 0) {
      std::memcpy(inst->state, inst->scratch, inst->state_bytes);
      return s;
    }
    if (s > worst) worst = s;
  }
  return worst;
}

}  // namespace

extern "C" {

FMI2_Export const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char* fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Component fmi2Instantiate(fmi2String instance_name, fmi2Type fmu_type, fmi2String fmu_guid,
                                          fmi2String fmu_resource_location,
                                          const fmi2CallbackFunctions* functions, fmi2Boolean visible,
                                          fmi2Boolean logging_on) {
  (void)visible;
  if (functions == nullptr) return nullptr;
  Instance probe;  // for logging before the instance exists
  probe.logger = functions->logger;
  probe.environment = functions->componentEnvironment;
  probe.name = const_cast<char*>(instance_name);
  if (functions->allocateMemory == nullptr || functions->freeMemory == nullptr)
    return fail(&probe, "fmi2Instantiate: allocateMemory and freeMemory must be given"), nullptr;
  if (instance_name == nullptr || instance_name[0] == '\0')
    return fail(&probe, "fmi2Instantiate: an instance name is required"), nullptr;
  if (fmu_type != fmi2CoSimulation)
    return fail(&probe, "fmi2Instantiate: this FMU is for co-simulation only (fmi2CoSimulation)"), nullptr;
  if (fmu_guid == nullptr) return fail(&probe, "fmi2Instantiate: fmuGUID is NULL"), nullptr;
  Instance* inst = static_cast<Instance*>(functions->allocateMemory(1, sizeof(Instance)));
  if (inst == nullptr) return fail(&probe, "fmi2Instantiate: out of memory"), nullptr;
  inst = new (inst) Instance();  // placement new: the object now exists in the importer's memory
  inst->logger = functions->logger;
  inst->allocate = functions->allocateMemory;
  inst->free_memory = functions->freeMemory;
  inst->environment = functions->componentEnvironment;
  inst->logging_on = logging_on != fmi2False;
  const std::size_t name_bytes = std::strlen(instance_name) + 1;
  inst->name = static_cast<char*>(allocate(inst, name_bytes));
  if (inst->name == nullptr) {
    inst->~Instance();
    functions->freeMemory(inst);
    return fail(&probe, "fmi2Instantiate: out of memory"), nullptr;
  }
  std::memcpy(inst->name, instance_name, name_bytes);
  if (!load_model(inst, fmu_guid, fmu_resource_location)) {
    free_parts(inst);
    inst->~Instance();
    functions->freeMemory(inst);
    return nullptr;
  }
  reset_values(inst);
  inst->magic = kLiveMagic;
  register_instance(inst);
  return inst;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
  Instance* inst = live(c);
  if (inst == nullptr || !unregister_instance(inst)) return;
  inst->magic = 0;
  free_parts(inst);
  fmi2CallbackFreeMemory free_memory = inst->free_memory;
  inst->~Instance();
  free_memory(inst);
}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean logging_on, size_t n_categories,
                                           const fmi2String categories[]) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2SetDebugLogging", kAnyPhase, &st);
  if (inst == nullptr) return st;
  if (n_categories > 0 && categories == nullptr)
    return fail(inst, "fmi2SetDebugLogging: categories is NULL");
  for (size_t i = 0; i < n_categories; ++i) {
    const char* k = categories[i];
    if (k == nullptr || (std::strcmp(k, "logStatusError") != 0 && std::strcmp(k, "logStatusWarning") != 0))
      return fail(inst, "fmi2SetDebugLogging: unknown log category '%s' (logStatusError, logStatusWarning)",
                  k != nullptr ? k : "(null)");
  }
  inst->logging_on = logging_on != fmi2False;
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolerance_defined, fmi2Real tolerance,
                                           fmi2Real start_time, fmi2Boolean stop_time_defined,
                                           fmi2Real stop_time) {
  (void)tolerance_defined;  // the step is the runtime's exact discretization: no tolerance
  (void)tolerance;
  fmi2Status st;
  Instance* inst = checked(c, "fmi2SetupExperiment", bit(Phase::instantiated), &st);
  if (inst == nullptr) return st;
  if (!std::isfinite(start_time)) return fail(inst, "fmi2SetupExperiment: startTime is not finite");
  if (stop_time_defined != fmi2False && !(std::isfinite(stop_time) && stop_time >= start_time))
    return fail(inst, "fmi2SetupExperiment: stopTime %g is not a finite time >= startTime %g", stop_time,
                start_time);
  inst->start_time_s = inst->time_s = start_time;
  inst->stop_time_defined = stop_time_defined != fmi2False;
  inst->stop_time_s = stop_time;
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2EnterInitializationMode", bit(Phase::instantiated), &st);
  if (inst == nullptr) return st;
  inst->phase = Phase::initialization;
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2ExitInitializationMode", bit(Phase::initialization), &st);
  if (inst == nullptr) return st;
  if (initialize_outputs(inst, "fmi2ExitInitializationMode") != fmi2OK) return fmi2Error;
  inst->time_s = inst->start_time_s;
  inst->last_step_s = 0.0;
  inst->phase = Phase::step_complete;
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2Terminate", bit(Phase::step_complete), &st);
  if (inst == nullptr) return st;
  inst->phase = Phase::terminated;
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2Reset", kAnyPhase, &st);
  if (inst == nullptr) return st;
  reset_values(inst);
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2GetReal", kAnyPhase & ~bit(Phase::instantiated), &st);
  if (inst == nullptr || nvr == 0) return st;
  if (vr == nullptr || value == nullptr) return fail(inst, "fmi2GetReal: vr or value is NULL");
  // In initialization mode the outputs follow the inputs and parameters set so far.
  for (size_t i = 0; i < nvr; ++i)
    if (inst->phase == Phase::initialization && is_coefficient(inst, vr[i])) {
      if (initialize_outputs(inst, "fmi2GetReal") != fmi2OK) return fmi2Error;
      break;
    }
  for (size_t i = 0; i < nvr; ++i) {
    if (settable_real(inst, vr[i]) == nullptr && !is_coefficient(inst, vr[i]))
      return fail(inst, "fmi2GetReal: no Real variable has value reference %u", vr[i]);
  }
  for (size_t i = 0; i < nvr; ++i) {
    const double* v = settable_real(inst, vr[i]);
    value[i] = v != nullptr ? *v : inst->out[vr[i] - fmu::vr_first_coefficient];
  }
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                   const fmi2Real value[]) {
  fmi2Status st;
  const unsigned allowed = bit(Phase::instantiated) | bit(Phase::initialization) | bit(Phase::step_complete);
  Instance* inst = checked(c, "fmi2SetReal", allowed, &st);
  if (inst == nullptr || nvr == 0) return st;
  if (vr == nullptr || value == nullptr) return fail(inst, "fmi2SetReal: vr or value is NULL");
  // Every value is checked before any is written: a refused call changes nothing.
  for (size_t i = 0; i < nvr; ++i) {
    if (settable_real(inst, vr[i]) == nullptr)
      return fail(inst, "fmi2SetReal: value reference %u is not an input or parameter", vr[i]);
    if (is_parameter(vr[i]) && inst->phase == Phase::step_complete)
      return fail(inst, "fmi2SetReal: parameter %u is fixed after initialization (fmi2Reset to change it)", vr[i]);
    if (!std::isfinite(value[i]))
      return fail(inst, "fmi2SetReal: value reference %u: %g is not finite", vr[i], value[i]);
    if (is_airspeed(vr[i]) && !(value[i] > 0.0))
      return fail(inst, "fmi2SetReal: value reference %u: airspeed %g m/s must be > 0", vr[i], value[i]);
  }
  for (size_t i = 0; i < nvr; ++i) *settable_real(inst, vr[i]) = value[i];
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Integer value[]) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2GetInteger", kAnyPhase & ~bit(Phase::instantiated), &st);
  if (inst == nullptr || nvr == 0) return st;
  if (vr == nullptr || value == nullptr) return fail(inst, "fmi2GetInteger: vr or value is NULL");
  for (size_t i = 0; i < nvr; ++i)
    if (vr[i] != fmu::vr_step_status)
      return fail(inst, "fmi2GetInteger: no Integer variable has value reference %u", vr[i]);
  for (size_t i = 0; i < nvr; ++i) value[i] = inst->step_status;
  return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Integer value[]) {
  (void)value;
  fmi2Status st;
  Instance* inst = checked(c, "fmi2SetInteger", kAnyPhase, &st);
  if (inst == nullptr || nvr == 0) return st;
  return fail(inst, "fmi2SetInteger: value reference %u is not settable (step_status is an output)",
              vr != nullptr ? vr[0] : 0u);
}

// No Boolean or String variables: only empty calls succeed.
static fmi2Status no_variables(fmi2Component c, const char* function, size_t nvr) {
  fmi2Status st;
  Instance* inst = checked(c, function, kAnyPhase, &st);
  if (inst == nullptr || nvr == 0) return st;
  return fail(inst, "%s: this FMU has no variables of that type", function);
}

FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  return no_variables(c, "fmi2GetBoolean", nvr);
}
FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                      const fmi2Boolean value[]) {
  (void)vr;
  (void)value;
  return no_variables(c, "fmi2SetBoolean", nvr);
}
FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     fmi2String value[]) {
  (void)vr;
  (void)value;
  return no_variables(c, "fmi2GetString", nvr);
}
FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                     const fmi2String value[]) {
  (void)vr;
  (void)value;
  return no_variables(c, "fmi2SetString", nvr);
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real current_communication_point,
                                  fmi2Real communication_step_size,
                                  fmi2Boolean no_set_fmu_state_prior_to_current_point) {
  (void)no_set_fmu_state_prior_to_current_point;
  fmi2Status st;
  Instance* inst = checked(c, "fmi2DoStep", bit(Phase::step_complete), &st);
  if (inst == nullptr) return st;
  const double t = current_communication_point;
  const double h = communication_step_size;
  if (!std::isfinite(t) || !std::isfinite(h) || !(h > 0.0))
    return fail(inst, "fmi2DoStep: communication point %g and step size %g must be finite, the step > 0", t, h);
  if (h > kMaxCommunicationStepS)
    return fail(inst, "fmi2DoStep: step size %g s is above the largest accepted step, %g s (a step in ms passed as s?)",
                h, kMaxCommunicationStepS);
  const double tol = communication_tolerance_s(inst->time_s, t, h, inst->last_step_s);
  if (std::fabs(t - inst->time_s) > tol)
    return fail(inst, "fmi2DoStep: communication point %.17g is not the FMU's time %.17g (a step skipped or repeated?)",
                t, inst->time_s);
  if (inst->stop_time_defined && t + h > inst->stop_time_s + communication_tolerance_s(inst->stop_time_s, t + h, h, 0.0))
    return fail(inst, "fmi2DoStep: the step to %.17g passes stopTime %.17g", t + h, inst->stop_time_s);
  double out[kMaxOutputs] = {};
  const int s = step_held(inst, h, out);
  if (s < 0) {
    inst->step_status = s;
    return fail(inst, "fmi2DoStep: the runtime refused the step from t = %.17g by %g s: %s", t, h,
                indicial_status_string(s));
  }
  for (int i = 0; i < inst->n_outputs; ++i) inst->out[i] = out[i];
  inst->step_status = s;
  if (s == INDICIAL_ANGLE_CLAMPED)
    warn(inst, "fmi2DoStep: angle %g rad is outside the model's envelope: clamped", inst->in.angle_rad);
  inst->time_s = t + h;
  inst->last_step_s = h;
  return fmi2OK;
}

// ---- capabilities the description declares absent: refused, never undefined -----------------
FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2CancelStep", kAnyPhase, &st);
  if (inst == nullptr) return st;
  return fail(inst, "fmi2CancelStep: fmi2DoStep never returns fmi2Pending: nothing to cancel");
}

static fmi2Status unsupported(fmi2Component c, const char* function, const char* why) {
  fmi2Status st;
  Instance* inst = checked(c, function, kAnyPhase, &st);
  if (inst == nullptr) return st;
  return fail(inst, "%s: not supported (%s)", function, why);
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* state) {
  (void)state;
  return unsupported(c, "fmi2GetFMUstate", "canGetAndSetFMUstate=\"false\"");
}
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
  (void)state;
  return unsupported(c, "fmi2SetFMUstate", "canGetAndSetFMUstate=\"false\"");
}
FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* state) {
  (void)state;
  return unsupported(c, "fmi2FreeFMUstate", "canGetAndSetFMUstate=\"false\"");
}
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t* size) {
  (void)state;
  (void)size;
  return unsupported(c, "fmi2SerializedFMUstateSize", "canSerializeFMUstate=\"false\"");
}
FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte serialized[],
                                             size_t size) {
  (void)state;
  (void)serialized;
  (void)size;
  return unsupported(c, "fmi2SerializeFMUstate", "canSerializeFMUstate=\"false\"");
}
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serialized[], size_t size,
                                               fmi2FMUstate* state) {
  (void)serialized;
  (void)size;
  (void)state;
  return unsupported(c, "fmi2DeSerializeFMUstate", "canSerializeFMUstate=\"false\"");
}
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference unknown[],
                                                    size_t n_unknown, const fmi2ValueReference known[],
                                                    size_t n_known, const fmi2Real known_delta[],
                                                    fmi2Real unknown_delta[]) {
  (void)unknown;
  (void)n_unknown;
  (void)known;
  (void)n_known;
  (void)known_delta;
  (void)unknown_delta;
  return unsupported(c, "fmi2GetDirectionalDerivative", "providesDirectionalDerivative=\"false\"");
}
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr;
  (void)nvr;
  (void)order;
  (void)value;
  return unsupported(c, "fmi2SetRealInputDerivatives", "canInterpolateInputs=\"false\"");
}
FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[]) {
  (void)vr;
  (void)nvr;
  (void)order;
  (void)value;
  return unsupported(c, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder=\"0\"");
}

// ---- status queries: doStep is synchronous, so only the last successful time is known -------
// The answer to a status query that has none: fmi2Discard (or fmi2Error for a stranger).
static fmi2Status no_status(fmi2Component c, const char* function) {
  fmi2Status st;
  return checked(c, function, kAnyPhase, &st) == nullptr ? st : fmi2Discard;
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Status* value) {
  (void)kind;
  (void)value;
  return no_status(c, "fmi2GetStatus");
}
FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Real* value) {
  fmi2Status st;
  Instance* inst = checked(c, "fmi2GetRealStatus", kAnyPhase, &st);
  if (inst == nullptr) return st;
  if (kind != fmi2LastSuccessfulTime || value == nullptr) return fmi2Discard;
  *value = inst->time_s;
  return fmi2OK;
}
FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Integer* value) {
  (void)kind;
  (void)value;
  return no_status(c, "fmi2GetIntegerStatus");
}
FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Boolean* value) {
  if (kind != fmi2Terminated || value == nullptr) return no_status(c, "fmi2GetBooleanStatus");
  fmi2Status st;
  if (checked(c, "fmi2GetBooleanStatus", kAnyPhase, &st) == nullptr) return st;
  *value = fmi2False;  // the slave never asks to end the simulation
  return fmi2OK;
}
FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind kind, fmi2String* value) {
  (void)kind;
  (void)value;
  return no_status(c, "fmi2GetStringStatus");
}

}  // extern "C"
