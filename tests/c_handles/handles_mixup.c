/* tests/c_handles/handles_mixup.c -- must NOT compile (ctest c_handles_mixup_refused): the
 * model and the state handles swapped. With -DINDICIAL_MIXUP_FIXED the same call in the right
 * order, which must compile (so the refusal is the mix-up's, not the file's). Compiled as C99
 * with -Werror=incompatible-pointer-types and as C++ (check_mixup.cmake). */
#include "indicial/indicial.h"

int use(indicial_model* model, indicial_state* state, double* out) {
#ifdef INDICIAL_MIXUP_FIXED
  return indicial_state_step(model, state, 0.1, 0.0, 20.0, 0.01, out);
#else
  return indicial_state_step(state, model, 0.1, 0.0, 20.0, 0.01, out);
#endif
}
