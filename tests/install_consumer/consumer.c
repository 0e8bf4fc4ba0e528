/* Loads a coefficient file through the installed C interface. */
#include <stdio.h>
#include <string.h>

#include "indicial/indicial.h"

static double model[4096];

int main(int argc, char** argv) {
  static char text[16384];
  char error[128];
  size_t n;
  FILE* f;
  if (argc != 2 || (f = fopen(argv[1], "rb")) == NULL) return 1;
  n = fread(text, 1, sizeof text, f);
  fclose(f);
  if (indicial_model_bytes() > sizeof model) return 2;
  if (indicial_model_load(model, text, n, error, sizeof error) != 0) {
    printf("consumer_c: %s\n", error);
    return 3;
  }
  printf("consumer_c: %d outputs, first %s\n", indicial_model_outputs(model),
         indicial_model_output_name(model, 0));
  return strcmp(indicial_model_output_name(model, 0), "CL") == 0 ? 0 : 4;
}
