/* indicial/indicial.h -- the C99 interface of the indicial runtime (library indicial::c).
 *
 * What it is for
 * --------------
 * Simulink S-functions, FMUs, Python ctypes and Fortran (OpenFAST) call C, not C++ templates.
 * This header exposes the runtime (runtime.hpp: RuntimeModel<double, DefaultCapacity>, its
 * State / DelayedState and the stateless step) with plain types. No heap: the caller provides
 * the storage of the model and of every state, sized by the functions below. No exceptions
 * cross it; every call returns a status.
 *
 * Usage (the untyped functions of the first version; the typed handles below, since 0.2, are
 * the same calls with a model and a state that cannot be swapped)
 * -----
 *   double* model = malloc(indicial_model_bytes());          (or a static double array)
 *   char error[128];
 *   if (indicial_model_load(model, text, text_length, error, sizeof error) != 0) { puts(error); }
 *   void* state = malloc(indicial_state_bytes(model));
 *   indicial_reset(model, state, alpha_rad, airspeed_mps);
 *   double out[3];                                            (indicial_model_outputs(model))
 *   int s = indicial_step(model, state, alpha_rad, q_radps, airspeed_mps, dt_s, out);
 *   if (s < 0) fprintf(stderr, "%s\n", indicial_status_string(s));
 *   ... out[0] is indicial_model_output_name(model, 0) ("CL"), out[1] the next ("Cm") ...
 *
 * Statuses: 0 ok; positive: a warning, the step was done (INDICIAL_ANGLE_CLAMPED); negative:
 * an error, nothing was changed (neither the model, the state nor out). Load errors are
 * -(100 + the C++ LoadStatus), step errors -(the C++ StepStatus); the values are listed below
 * and never renumbered.
 *
 * Warnings
 * --------
 * 1. Storage must be aligned for a double (malloc, or an array of double); misaligned storage
 *    is refused (INDICIAL_ERROR_MISALIGNED). A model's storage may be shared by any number of
 *    states and threads once loaded (it is read-only after the load).
 * 2. indicial_state_bytes depends on the model: a model with a delay needs the delay history
 *    (about 4.4 KB); one with dynamic-stall families (a version-2 coefficient file with sep_*
 *    / vortex_* keys) their states (256 bytes); otherwise 160 bytes. Size states after loading
 *    the model.
 * 3. A state must be written by indicial_reset before its first step (a zeroed state answers
 *    INDICIAL_ERROR_NOT_RESET; uninitialised memory is undefined), and belongs to the model it
 *    was reset with.
 * 4. indicial_model_load keeps about 40 KB on the stack (the parser's and the validated model):
 *    load at initialisation, not from an interrupt.
 * 5. Angles in rad, rates in rad/s, airspeed in m/s, time in s. Inputs per axis as in the C++
 *    runtime: pitch alpha, q; roll phi, p; yaw psi, r.
 */
#ifndef INDICIAL_INDICIAL_H
#define INDICIAL_INDICIAL_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Status values (returned by every function that returns int, except indicial_model_outputs). */
#define INDICIAL_OK 0
#define INDICIAL_ANGLE_CLAMPED 1                 /* done; the model angle was clamped */
#define INDICIAL_ERROR_NOT_LOADED (-2)           /* the model storage holds no loaded model */
#define INDICIAL_ERROR_NOT_RESET (-3)            /* the state was never reset */
#define INDICIAL_ERROR_NULL_OUTPUT (-4)          /* out == NULL */
#define INDICIAL_ERROR_NON_FINITE_INPUT (-5)     /* an input is NaN or Inf */
#define INDICIAL_ERROR_NON_POSITIVE_DT (-6)      /* dt_s <= 0 */
#define INDICIAL_ERROR_DT_TOO_LARGE (-7)         /* dt_s > 1 s */
#define INDICIAL_ERROR_NON_POSITIVE_AIRSPEED (-8)
#define INDICIAL_ERROR_NON_FINITE_RESULT (-9)    /* absurd input would give NaN/Inf: refused */
#define INDICIAL_ERROR_DELAY_EXCEEDS_HISTORY (-10)
#define INDICIAL_ERROR_DELAY_NEEDS_HISTORY (-11)
#define INDICIAL_ERROR_FAMILIES_NEED_STATE (-12) /* C++ only: a family model on a plain State */
#define INDICIAL_ERROR_EMPTY_INPUT (-101)        /* load: no bytes, or only whitespace */
#define INDICIAL_ERROR_NULL_ARGUMENT (-102)      /* a required pointer is NULL */
#define INDICIAL_ERROR_TRUNCATED (-103)
#define INDICIAL_ERROR_CHECKSUM_MISMATCH (-104)
#define INDICIAL_ERROR_WRONG_VERSION (-105)
#define INDICIAL_ERROR_OVER_CAPACITY (-106)
#define INDICIAL_ERROR_SYNTAX (-107)
#define INDICIAL_ERROR_INVALID_VALUE (-108)
#define INDICIAL_ERROR_UNSUPPORTED_FEATURE (-109)
#define INDICIAL_ERROR_UNSTABLE_LAG (-110)
#define INDICIAL_ERROR_MISALIGNED (-200)         /* model or state storage not double-aligned */
#define INDICIAL_ERROR_STORAGE_TOO_SMALL (-201)  /* typed init: storage_bytes below the size needed */

/* Bytes of storage for one model (the same for every model). */
size_t indicial_model_bytes(void);

/* Parses and validates a coefficient file's text into *model. 0 = ok; on error the model
 * storage is unchanged and, if error != NULL, error holds "line N: reason (status)"
 * (NUL-terminated, cut to error_length). */
int indicial_model_load(void* model, const char* text, size_t length, char* error,
                        size_t error_length);

/* Number of coefficients the model outputs (1..3), or a negative status. */
int indicial_model_outputs(const void* model);

/* Name of output i ("CL", "Cm", ...), or NULL if i is out of range or nothing is loaded. */
const char* indicial_model_output_name(const void* model, int i);

/* The airspeed the model was identified at (m/s; its steps accept any airspeed > 0), or 0 if
 * nothing is loaded. */
double indicial_model_reference_airspeed_mps(const void* model);

/* Bytes of storage for one state of this model (0 if nothing is loaded). */
size_t indicial_state_bytes(const void* model);

/* Steady state at the motion angle; must precede the first step of a state. */
int indicial_reset(const void* model, void* state, double angle_rad, double airspeed_mps);

/* One step of dt_s to this sample; out receives indicial_model_outputs(model) values. */
int indicial_step(const void* model, void* state, double angle_rad, double rate_radps,
                  double airspeed_mps, double dt_s, double* out);

/* The outputs at the state's current sample without stepping: its angle and lag states, with
 * this rate and airspeed, on the step's angles (a static table at the angle itself, every other
 * term at the envelope's edge when the angle left it) -- e.g. the outputs at the first sample, just after
 * indicial_reset (what `indicial predict` writes there). Changes nothing; out receives
 * indicial_model_outputs(model) values only if every one is finite. */
int indicial_evaluate(const void* model, const void* state, double rate_radps,
                      double airspeed_mps, double* out);

/* n instances of one model: states are n consecutive states of indicial_state_bytes(model)
 * bytes each, as indicial_reset writes them; out receives n rows of
 * indicial_model_outputs(model) values. Returns the first error of any instance (that
 * instance unchanged, the others stepped), else INDICIAL_ANGLE_CLAMPED if any was clamped,
 * else 0. */
int indicial_step_batch(const void* model, void* states, size_t n, const double* angle_rad,
                        const double* rate_radps, const double* airspeed_mps, double dt_s,
                        double* out);

/* "ok", "angle_clamped", "checksum_mismatch", ...: a static string for any status. */
const char* indicial_status_string(int status);

/* ------------------------------------------------------------------------------------------
 * Typed handles (since 0.2). The functions above take the model's and the state's storage as
 * void*, so a state passed where the model belongs (or the reverse) compiles and is refused
 * only at run time. The functions below take distinct opaque handle types: a mix-up is a
 * compile error in C++ and, in C, a constraint violation that C compilers diagnose (an error
 * with -Werror or -Werror=incompatible-pointer-types, the default since GCC 14). A handle is
 * the address of the caller's storage, typed: it is valid as long as that storage is, and it
 * converts to void*, so handles may be passed to the untyped functions above too.
 *
 *   static double model_storage[4096], state_storage[64];
 *   indicial_model* model = NULL;
 *   indicial_state* state = NULL;
 *   if (indicial_model_init(model_storage, sizeof model_storage, text, text_length, error,
 *                           sizeof error, &model) != 0) { puts(error); }
 *   indicial_state_init(model, state_storage, sizeof state_storage, alpha_rad, airspeed_mps,
 *                       &state);
 *   int s = indicial_state_step(model, state, alpha_rad, q_radps, airspeed_mps, dt_s, out);
 * ------------------------------------------------------------------------------------------ */
typedef struct indicial_model indicial_model; /* opaque: a loaded model in caller storage */
typedef struct indicial_state indicial_state; /* opaque: one instance's state */

/* The library's version, "MAJOR.MINOR.PATCH" (the project's version; `indicial --version`
 * prints the same), a static string. INDICIAL_C_API is the interface's own level: 1 the
 * untyped functions, 2 adds the typed handles and indicial_version. */
#define INDICIAL_C_API 2
const char* indicial_version(void);

/* Loads text into storage of storage_bytes bytes (at least indicial_model_bytes(), aligned for
 * a double) as indicial_model_load does; *model is the handle on success, NULL on error
 * (INDICIAL_ERROR_STORAGE_TOO_SMALL when storage_bytes is too small). */
int indicial_model_init(void* storage, size_t storage_bytes, const char* text, size_t length,
                        char* error, size_t error_length, indicial_model** model);

/* indicial_model_outputs, indicial_model_output_name and indicial_state_bytes on a handle. */
int indicial_model_output_count(const indicial_model* model);
const char* indicial_model_output_label(const indicial_model* model, int i);
size_t indicial_model_state_bytes(const indicial_model* model);

/* indicial_model_reference_airspeed_mps on a handle. */
double indicial_model_airspeed_mps(const indicial_model* model);

/* Resets storage of storage_bytes bytes (at least indicial_model_state_bytes(model), aligned
 * for a double) as a state of model at the motion angle; *state is the handle on success,
 * NULL on error (INDICIAL_ERROR_STORAGE_TOO_SMALL when storage_bytes is too small). */
int indicial_state_init(const indicial_model* model, void* storage, size_t storage_bytes,
                        double angle_rad, double airspeed_mps, indicial_state** state);

/* indicial_reset, indicial_step, indicial_evaluate and indicial_step_batch on handles; states of a batch are n
 * consecutive states, each indicial_model_state_bytes(model) bytes, the first at `states`. */
int indicial_state_reset(const indicial_model* model, indicial_state* state, double angle_rad,
                         double airspeed_mps);
int indicial_state_step(const indicial_model* model, indicial_state* state, double angle_rad,
                        double rate_radps, double airspeed_mps, double dt_s, double* out);
int indicial_state_evaluate(const indicial_model* model, const indicial_state* state,
                            double rate_radps, double airspeed_mps, double* out);
int indicial_state_step_batch(const indicial_model* model, indicial_state* states, size_t n,
                              const double* angle_rad, const double* rate_radps,
                              const double* airspeed_mps, double dt_s, double* out);

#ifdef __cplusplus
}
#endif

#endif /* INDICIAL_INDICIAL_H */
