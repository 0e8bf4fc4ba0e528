/* tests/c_handles/c_handles_test.c -- the typed handles of the C interface (indicial.h,
 * "Typed handles"), from a C99 program compiled with -Werror. Usage:
 *   c_handles_test SOURCE_DIR PROJECT_VERSION
 * Loads examples/synthetic-lift-moment.coef through indicial_model_init and through the untyped
 * indicial_model_load, steps one state of each on the same motion and requires bit-identical
 * outputs (the typed calls are the same calls); a batch through the typed call against single
 * steps; indicial_version() against the project's version; the storage-size refusals (handle
 * left NULL, storage unchanged). Prints one line per failure and exits 1 if any. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "indicial/indicial.h"

static int failures = 0;

#define CHECK(cond)                                                          \
  do {                                                                       \
    if (!(cond)) {                                                           \
      fprintf(stderr, "c_handles_test:%d: CHECK(%s) failed\n", __LINE__, #cond); \
      ++failures;                                                            \
    }                                                                        \
  } while (0)

enum { n_samples = 300, n_batch = 5, max_text = 16384 };
static const double dt_s = 0.005;
static const double airspeed_mps = 19.5;

static double typed_model_storage[4096], untyped_model_storage[4096];
static double typed_state_storage[64], untyped_state_storage[64];
static double batch_storage[n_batch][64];

static double angle_at(int k) { return 0.6 + 0.45 * sin(6.9 * dt_s * k); }
static double rate_at(int k) { return 0.45 * 6.9 * cos(6.9 * dt_s * k); }

static void check_same_as_untyped(const indicial_model* model, indicial_state* state) {
  double typed[3], untyped[3];
  int k;
  CHECK(indicial_reset(untyped_model_storage, untyped_state_storage, angle_at(0), airspeed_mps) == INDICIAL_OK);
  CHECK(indicial_state_evaluate(model, state, rate_at(0), airspeed_mps, typed) == INDICIAL_OK);
  CHECK(indicial_evaluate(untyped_model_storage, untyped_state_storage, rate_at(0), airspeed_mps, untyped) == INDICIAL_OK);
  CHECK(memcmp(typed, untyped, 2 * sizeof(double)) == 0);
  for (k = 1; k < n_samples; ++k) {
    const int a = indicial_state_step(model, state, angle_at(k), rate_at(k), airspeed_mps, dt_s, typed);
    const int b = indicial_step(untyped_model_storage, untyped_state_storage, angle_at(k), rate_at(k),
                                airspeed_mps, dt_s, untyped);
    CHECK(a == b && a >= 0);
    CHECK(memcmp(typed, untyped, 2 * sizeof(double)) == 0);
  }
}

static void check_batch(const indicial_model* model) {
  const size_t bytes = indicial_model_state_bytes(model);
  double angle[n_batch], rate[n_batch], speed[n_batch], out[n_batch * 2], single[2];
  indicial_state* first = NULL;
  indicial_state* handles[n_batch];
  int i, k;
  CHECK(bytes <= sizeof batch_storage[0]);
  for (i = 0; i < n_batch; ++i) {
    CHECK(indicial_state_init(model, batch_storage[i], sizeof batch_storage[i], angle_at(i), airspeed_mps,
                              &handles[i]) == INDICIAL_OK);
  }
  /* n consecutive states for the batch: copy each into one packed buffer. */
  {
    static double packed[n_batch * 64];
    for (i = 0; i < n_batch; ++i) memcpy((char*)packed + (size_t)i * bytes, batch_storage[i], bytes);
    first = (indicial_state*)(void*)packed;
    for (k = 1; k < 50; ++k) {
      for (i = 0; i < n_batch; ++i) {
        angle[i] = angle_at(k + i);
        rate[i] = rate_at(k + i);
        speed[i] = airspeed_mps;
      }
      CHECK(indicial_state_step_batch(model, first, n_batch, angle, rate, speed, dt_s, out) >= 0);
      for (i = 0; i < n_batch; ++i) {
        CHECK(indicial_state_step(model, handles[i], angle[i], rate[i], speed[i], dt_s, single) >= 0);
        CHECK(fabs(single[0] - out[2 * i]) <= 1e-12 && fabs(single[1] - out[2 * i + 1]) <= 1e-12);
      }
    }
  }
}

static void check_refusals(const char* text, size_t length) {
  static double small_model[4];
  double before[4];
  char error[128];
  indicial_model* model = (indicial_model*)(void*)typed_model_storage;
  indicial_state* state = (indicial_state*)(void*)typed_state_storage;
  memcpy(before, small_model, sizeof before);
  CHECK(indicial_model_init(small_model, sizeof small_model, text, length, error, sizeof error, &model) ==
        INDICIAL_ERROR_STORAGE_TOO_SMALL);
  CHECK(model == NULL);
  CHECK(memcmp(before, small_model, sizeof before) == 0);
  CHECK(strstr(error, "smaller than indicial_model_bytes") != NULL);
  CHECK(strcmp(indicial_status_string(INDICIAL_ERROR_STORAGE_TOO_SMALL), "storage_too_small") == 0);
  CHECK(indicial_model_init(untyped_model_storage, sizeof untyped_model_storage, text, length, error,
                            sizeof error, NULL) == INDICIAL_ERROR_NULL_ARGUMENT);
  CHECK(indicial_model_init(typed_model_storage, sizeof typed_model_storage, text, length, error,
                            sizeof error, &model) == INDICIAL_OK);
  CHECK(indicial_state_init(model, batch_storage[0], 8, 0.5, 20.0, &state) == INDICIAL_ERROR_STORAGE_TOO_SMALL);
  CHECK(state == NULL);
  CHECK(indicial_state_init(model, batch_storage[0], sizeof batch_storage[0], 0.5, 20.0, NULL) ==
        INDICIAL_ERROR_NULL_ARGUMENT);
}

int main(int argc, char** argv) {
  static char text[max_text];
  char path[1024], error[128];
  size_t length = 0;
  FILE* f;
  indicial_model* model = NULL;
  indicial_state* state = NULL;
  if (argc != 3) {
    fprintf(stderr, "usage: c_handles_test SOURCE_DIR PROJECT_VERSION\n");
    return 2;
  }
  CHECK(INDICIAL_C_API >= 2);
  CHECK(strcmp(indicial_version(), argv[2]) == 0);
  snprintf(path, sizeof path, "%s/examples/synthetic-lift-moment.coef", argv[1]);
  f = fopen(path, "rb");
  if (f != NULL) {
    length = fread(text, 1, sizeof text, f);
    fclose(f);
  }
  CHECK(length > 0);
  CHECK(indicial_model_init(typed_model_storage, sizeof typed_model_storage, text, length, error,
                            sizeof error, &model) == INDICIAL_OK);
  CHECK(model == (indicial_model*)(void*)typed_model_storage);
  CHECK(indicial_model_load(untyped_model_storage, text, length, error, sizeof error) == INDICIAL_OK);
  if (model == NULL) return 1;
  CHECK(indicial_model_output_count(model) == 2);
  CHECK(strcmp(indicial_model_output_label(model, 1), "Cm") == 0);
  CHECK(indicial_model_airspeed_mps(model) == indicial_model_reference_airspeed_mps(untyped_model_storage));
  CHECK(indicial_model_state_bytes(model) == indicial_state_bytes(untyped_model_storage));
  CHECK(indicial_state_init(model, typed_state_storage, sizeof typed_state_storage, angle_at(0), airspeed_mps,
                            &state) == INDICIAL_OK);
  CHECK(state != NULL);
  if (state != NULL) check_same_as_untyped(model, state);
  /* A handle is the storage: the untyped calls accept it. */
  CHECK(indicial_model_outputs(model) == 2);
  CHECK(indicial_state_reset(model, state, 0.5, airspeed_mps) == INDICIAL_OK);
  check_batch(model);
  check_refusals(text, length);
  if (failures != 0) {
    fprintf(stderr, "c_handles_test: %d check(s) failed\n", failures);
    return 1;
  }
  printf("c_handles_test: all checks passed\n");
  return 0;
}
