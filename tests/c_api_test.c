/* tests/c_api_test.c -- the C interface (indicial/indicial.h) from a C99 program, compiled with
 * -std=c99 -Wall -Wextra -Werror (tests/CMakeLists.txt). Usage:
 *   c_api_test INDICIAL_EXE SOURCE_DIR WORK_DIR
 * Loads examples/synthetic-lift-moment.coef (C_L and C_m in one model), steps it on a motion,
 * runs `indicial predict` on the same motion and compares every sample to 1e-12; steps a batch
 * of instances and compares with single steps to 1e-12 relative; checks the refusals. Then the
 * same comparisons for examples/dynamic-stall-lift-moment.coef (both dynamic-stall families on
 * C_L and C_m, a deep-stall motion). Prints one line per failure and exits 1 if any. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "indicial/indicial.h"

static int failures = 0;

#define CHECK(cond)                                                   \
  do {                                                                \
    if (!(cond)) {                                                    \
      fprintf(stderr, "c_api_test:%d: CHECK(%s) failed\n", __LINE__, #cond); \
      ++failures;                                                     \
    }                                                                 \
  } while (0)

enum { n_samples = 400, n_batch = 37, max_text = 16384 };
static const double dt_s = 0.005;
static const double airspeed_mps = 19.5;

/* Storage for the model and states: arrays of double, so aligned for the runtime. */
static double model_storage[4096];
static double state_storage[n_batch][64];
static double single_storage[64];

static size_t read_file(const char* path, char* buffer, size_t capacity) {
  FILE* f = fopen(path, "rb");
  size_t n = 0;
  if (f == NULL) return 0;
  n = fread(buffer, 1, capacity, f);
  fclose(f);
  return n;
}

/* The motion: mean + amplitude sin(2 pi frequency t + phase), inside the model's envelope. */
static double motion_mean_rad = 0.6;
static double motion_amplitude_rad = 0.45;
static double motion_hz = 1.1;

static double angle_at(int k, double phase) {
  const double t = dt_s * k;
  return motion_mean_rad + motion_amplitude_rad * sin(2.0 * 3.14159265358979323846 * motion_hz * t + phase);
}

static double rate_at(int k, double phase) {
  const double t = dt_s * k;
  const double w = 2.0 * 3.14159265358979323846 * motion_hz;
  return motion_amplitude_rad * w * cos(w * t + phase);
}

static int close_to(double a, double b, double tolerance) {
  const double scale = fabs(b) > 1.0 ? fabs(b) : 1.0;
  return fabs(a - b) <= tolerance * scale;
}

/* Writes the motion as a run CSV, runs `indicial predict`, and reads CL_pred and Cm_pred
 * (columns 3 and 5) of every sample into predicted[k][0..1]. Returns the rows read. */
static int predict_with_cli(const char* exe, const char* model_path, const char* work,
                            double predicted[][2]) {
  char csv[1024], out[1024], command[8192], line[1024];
  FILE* f;
  int k, rows = 0;
  snprintf(csv, sizeof csv, "%s/c_api_motion.csv", work);
  snprintf(out, sizeof out, "%s/c_api_predicted.csv", work);
  f = fopen(csv, "w");
  if (f == NULL) return -1;
  fprintf(f, "time_s,alpha_rad,q_radps\n");
  for (k = 0; k < n_samples; ++k)
    fprintf(f, "%.17g,%.17g,%.17g\n", dt_s * k, angle_at(k, 0.0), rate_at(k, 0.0));
  fclose(f);
  snprintf(command, sizeof command, "\"%s\" predict \"%s\" \"%s\" --out \"%s\" --airspeed-mps %.17g --force > \"%s.log\" 2>&1",
          exe, model_path, csv, out, airspeed_mps, out);
  if (system(command) != 0) return -2;
  f = fopen(out, "r");
  if (f == NULL) return -3;
  while (fgets(line, sizeof line, f) != NULL && rows < n_samples) {
    double t, a, cl, cl_qs, cm;
    if (line[0] == '#' || line[0] == 't') continue;
    if (sscanf(line, "%lf,%lf,%lf,%lf,%lf", &t, &a, &cl, &cl_qs, &cm) != 5) break;
    predicted[rows][0] = cl;
    predicted[rows][1] = cm;
    ++rows;
  }
  fclose(f);
  return rows;
}

static void check_against_cli(const char* exe, const char* model_path, const char* work) {
  static double predicted[n_samples][2];
  double out[3];
  int k, compared = 0;
  const int rows = predict_with_cli(exe, model_path, work, predicted);
  CHECK(rows == n_samples);
  if (rows != n_samples) return;
  CHECK(indicial_reset(model_storage, single_storage, angle_at(0, 0.0), airspeed_mps) == INDICIAL_OK);
  for (k = 1; k < n_samples; ++k) {
    const int s = indicial_step(model_storage, single_storage, angle_at(k, 0.0), rate_at(k, 0.0),
                                airspeed_mps, dt_s, out);
    CHECK(s == INDICIAL_OK);
    compared += close_to(out[0], predicted[k][0], 1e-12) && close_to(out[1], predicted[k][1], 1e-12);
  }
  CHECK(compared == n_samples - 1);
  printf("c_api_test: %d samples of CL and Cm equal `indicial predict` to 1e-12\n", compared);
}

static void check_batch(void) {
  static double batch_out[n_batch * 2];
  static double single_out[n_batch][2];
  static double angle[n_batch], rate[n_batch], airspeed[n_batch];
  static double singles[n_batch][64];
  const size_t state_bytes = indicial_state_bytes(model_storage);
  int i, k, worst_ok = 1;
  double worst = 0.0;
  CHECK(state_bytes > 0 && state_bytes <= sizeof state_storage[0]);
  /* n consecutive states of state_bytes each, in one block of memory. */
  for (i = 0; i < n_batch; ++i) {
    char* base = (char*)state_storage + (size_t)i * state_bytes;
    CHECK(indicial_reset(model_storage, base, angle_at(0, 0.1 * i), airspeed_mps) == INDICIAL_OK);
    CHECK(indicial_reset(model_storage, singles[i], angle_at(0, 0.1 * i), airspeed_mps) == INDICIAL_OK);
  }
  for (k = 1; k < 200; ++k) {
    for (i = 0; i < n_batch; ++i) {
      angle[i] = angle_at(k, 0.1 * i);
      rate[i] = rate_at(k, 0.1 * i);
      airspeed[i] = airspeed_mps * (1.0 + 0.01 * i);
      CHECK(indicial_step(model_storage, singles[i], angle[i], rate[i], airspeed[i], dt_s,
                          single_out[i]) == INDICIAL_OK);
    }
    CHECK(indicial_step_batch(model_storage, state_storage, n_batch, angle, rate, airspeed, dt_s,
                              batch_out) == INDICIAL_OK);
    for (i = 0; i < n_batch; ++i) {
      int c;
      for (c = 0; c < 2; ++c) {
        /* Relative to the value, or to 0.01 where the coefficient crosses zero. */
        const double d = fabs(batch_out[2 * i + c] - single_out[i][c]) /
                         (fabs(single_out[i][c]) > 1e-2 ? fabs(single_out[i][c]) : 1e-2);
        if (d > worst) worst = d;
        if (!(d <= 1e-12)) worst_ok = 0;
      }
    }
  }
  CHECK(worst_ok);
  printf("c_api_test: batch of %d vs single steps: max relative difference %.3g\n", n_batch, worst);
}

static void check_refusals(const char* text, size_t length) {
  static double fresh[4096];
  static double copy[64];
  char error[128];
  double out[3] = {0.0, 0.0, 0.0};
  char damaged[max_text];
  /* Nothing loaded yet. */
  CHECK(indicial_model_outputs(fresh) == INDICIAL_ERROR_NOT_LOADED);
  CHECK(indicial_reset(fresh, copy, 0.5, 20.0) == INDICIAL_ERROR_NOT_LOADED);
  CHECK(indicial_state_bytes(fresh) == 0);
  /* A damaged file: refused with line, reason and status; the storage stays unloaded. */
  memcpy(damaged, text, length);
  damaged[length / 2] = (char)(damaged[length / 2] == '1' ? '2' : '1');
  CHECK(indicial_model_load(fresh, damaged, length, error, sizeof error) == INDICIAL_ERROR_CHECKSUM_MISMATCH);
  CHECK(strstr(error, "line ") == error);
  CHECK(strstr(error, "checksum_mismatch") != NULL);
  CHECK(indicial_model_outputs(fresh) == INDICIAL_ERROR_NOT_LOADED);
  CHECK(indicial_model_load(fresh, text, 0, error, sizeof error) == INDICIAL_ERROR_EMPTY_INPUT);
  CHECK(indicial_model_load((char*)fresh + 1, text, length, error, sizeof error) == INDICIAL_ERROR_MISALIGNED);
  /* Bad step input changes nothing; a never-reset state is refused. */
  memset(copy, 0, sizeof copy);
  CHECK(indicial_step(model_storage, copy, 0.5, 0.0, 20.0, 0.01, out) == INDICIAL_ERROR_NOT_RESET);
  CHECK(indicial_reset(model_storage, single_storage, 0.5, 20.0) == INDICIAL_OK);
  memcpy(copy, single_storage, indicial_state_bytes(model_storage));
  CHECK(indicial_step(model_storage, single_storage, NAN, 0.0, 20.0, 0.01, out) == INDICIAL_ERROR_NON_FINITE_INPUT);
  CHECK(indicial_step(model_storage, single_storage, 0.5, 0.0, 20.0, -0.01, out) == INDICIAL_ERROR_NON_POSITIVE_DT);
  CHECK(indicial_step(model_storage, single_storage, 0.5, 0.0, 0.0, 0.01, out) == INDICIAL_ERROR_NON_POSITIVE_AIRSPEED);
  CHECK(indicial_step(model_storage, single_storage, 0.5, 0.0, 20.0, 0.01, NULL) == INDICIAL_ERROR_NULL_OUTPUT);
  CHECK(memcmp(copy, single_storage, indicial_state_bytes(model_storage)) == 0);
  CHECK(out[0] == 0.0 && out[1] == 0.0);
  /* Outside the envelope: a warning (positive), outputs produced. */
  CHECK(indicial_step(model_storage, single_storage, 5.0, 0.0, 20.0, 0.01, out) == INDICIAL_ANGLE_CLAMPED);
  CHECK(isfinite(out[0]) && isfinite(out[1]));
  CHECK(strcmp(indicial_status_string(INDICIAL_OK), "ok") == 0);
  CHECK(strcmp(indicial_status_string(INDICIAL_ANGLE_CLAMPED), "angle_clamped") == 0);
  CHECK(strcmp(indicial_status_string(INDICIAL_ERROR_CHECKSUM_MISMATCH), "checksum_mismatch") == 0);
  CHECK(strcmp(indicial_status_string(INDICIAL_ERROR_DT_TOO_LARGE), "dt_too_large") == 0);
  CHECK(strcmp(indicial_status_string(-9999), "unknown_status") == 0);
}

/* The dynamic-stall example: a version-2 file, family states in the state (more bytes than a
 * plain state, at most 256), the same comparisons on a deep-stall cycle (10..24 deg at 4 Hz
 * and 19.5 m/s: k = 0.19). */
static void check_families(const char* exe, const char* source_dir, const char* work) {
  static char text[max_text];
  char path[1024], error[128];
  size_t length, plain_bytes;
  snprintf(path, sizeof path, "%s/examples/dynamic-stall-lift-moment.coef", source_dir);
  length = read_file(path, text, sizeof text);
  CHECK(length > 0 && length < sizeof text);
  plain_bytes = indicial_state_bytes(model_storage);
  CHECK(indicial_model_load(model_storage, text, length, error, sizeof error) == INDICIAL_OK);
  CHECK(indicial_model_outputs(model_storage) == 2);
  CHECK(indicial_state_bytes(model_storage) > plain_bytes);
  /* Issue 22 item 4: C_L + C_m with every family in at most 256 bytes, DefaultCapacity's three
     coefficient slots included (272 until the State stopped keeping the clamped angle and the
     padding word went; tests/test_runtime_families.cpp). */
  CHECK(indicial_state_bytes(model_storage) == 256);
  printf("c_api_test: dynamic-stall state %u bytes (without families %u)\n",
         (unsigned)indicial_state_bytes(model_storage), (unsigned)plain_bytes);
  motion_mean_rad = 0.2967;
  motion_amplitude_rad = 0.1222;
  motion_hz = 4.0;
  check_against_cli(exe, path, work);
  check_batch();
  {
    /* indicial_evaluate after a step gives that step's outputs (families included). */
    double stepped[3], evaluated[3];
    CHECK(indicial_reset(model_storage, single_storage, angle_at(0, 0.0), airspeed_mps) == INDICIAL_OK);
    CHECK(indicial_step(model_storage, single_storage, angle_at(1, 0.0), rate_at(1, 0.0), airspeed_mps,
                        dt_s, stepped) == INDICIAL_OK);
    CHECK(indicial_evaluate(model_storage, single_storage, rate_at(1, 0.0), airspeed_mps, evaluated) ==
          INDICIAL_OK);
    CHECK(memcmp(stepped, evaluated, 2 * sizeof(double)) == 0);
  }
}

int main(int argc, char** argv) {
  static char text[max_text];
  char model_path[1024];
  size_t length;
  if (argc != 4) {
    fprintf(stderr, "usage: c_api_test INDICIAL_EXE SOURCE_DIR WORK_DIR\n");
    return 2;
  }
  CHECK(indicial_model_bytes() <= sizeof model_storage);
  snprintf(model_path, sizeof model_path, "%s/examples/synthetic-lift-moment.coef", argv[2]);
  length = read_file(model_path, text, sizeof text);
  CHECK(length > 0);
  {
    char error[128];
    const int s = indicial_model_load(model_storage, text, length, error, sizeof error);
    CHECK(s == INDICIAL_OK);
    if (s != INDICIAL_OK) {
      fprintf(stderr, "c_api_test: load refused: %s\n", error);
      return 1;
    }
  }
  CHECK(indicial_model_outputs(model_storage) == 2);
  CHECK(strcmp(indicial_model_output_name(model_storage, 0), "CL") == 0);
  CHECK(strcmp(indicial_model_output_name(model_storage, 1), "Cm") == 0);
  CHECK(indicial_model_output_name(model_storage, 2) == NULL);
  CHECK(indicial_state_bytes(model_storage) <= 256);
  check_against_cli(argv[1], model_path, argv[3]);
  check_batch();
  check_refusals(text, length);
  check_families(argv[1], argv[2], argv[3]);
  if (failures != 0) {
    fprintf(stderr, "c_api_test: %d check(s) failed\n", failures);
    return 1;
  }
  printf("c_api_test: all checks passed\n");
  return 0;
}
