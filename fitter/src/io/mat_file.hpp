// Runs from MATLAB / Octave .mat files (v5 and v7.3, libmatio): the file's numeric vectors
// as named columns, to which the run reader applies the CSV column rules (mat_file.cpp).
#pragma once

#include <string>
#include <vector>

namespace indicial {

struct MatColumn {
  std::string name;            // the variable's (or struct field's) name: a column name
  std::vector<double> values;  // converted to double
};

struct MatUnusable {
  std::string name;    // the variable's (or field's) name
  std::string reason;  // "variable alpha_deg (5x2) is a matrix: a column is a vector"
};

struct MatColumns {
  std::vector<MatColumn> columns;     // in the file's order, all of one length
  std::vector<MatUnusable> unusable;  // what cannot be a column, and why
  std::vector<std::string> notes;     // structs ignored, for the user
  std::string version;             // "v5" or "v7.3"
};

// Whether a run path names a MAT-file (extension .mat, any case).
bool is_mat_file(const std::string& path);

// The columns of a run .mat; throws InputError naming the file and the variable at fault.
MatColumns read_mat_columns(const std::string& path);

}  // namespace indicial
