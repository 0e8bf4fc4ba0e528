// MAT-file runs (MATLAB / Octave .mat, v5 and v7.3) read with Debian's libmatio, as columns
// for the run reader (csv_reader.cpp), which applies the CSV column rules to them.
//
// What a run .mat holds (docs/formats.md, "Run files (.mat)"):
//   * variables named like the CSV's columns (time_s, alpha_deg, q_degps, Cm, ...), each a real
//     numeric vector (row or column; double, single or integer) of one common length; or
//   * one 1x1 struct whose fields are such vectors (a struct per run, the way many tunnel
//     scripts save them), when the file has no top-level numeric vector.
// Anything else -- a char array, a matrix, complex or sparse data, a logical, a cell, an
// empty vector, a vector of another length than the time (or phase) vector -- cannot be a
// column: it is listed in MatColumns::unusable with the reason, and the run reader refuses it
// (naming variable and reason) only if it is a column it reads, else notes it as ignored,
// as an unread CSV column is (calibration matrices and description strings are common).
// A struct array, several structs without top-level vectors, or no vector at all are refused.
//
// Warnings
// 1. matio reports problems through its log; the messages of a failed open are captured and
//    put into the error (a thread-local buffer: the readers may run in parallel).
// 2. v7.3 files are HDF5: they need matio built with HDF5 (Debian's libmatio11 is).
#include "io/mat_file.hpp"

#include <matio.h>

#include <algorithm>
#include <cctype>
#include <memory>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"

namespace indicial {
namespace {

thread_local std::string matio_last_message;

void capture_matio_log(int /*level*/, char* message) {
  if (message != nullptr) matio_last_message = message;
}

struct MatCloser {
  void operator()(mat_t* m) const { Mat_Close(m); }
};
struct VarFreer {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};
using MatFile = std::unique_ptr<mat_t, MatCloser>;
using MatVar = std::unique_ptr<matvar_t, VarFreer>;

std::string dims_text(const matvar_t* v) {
  std::string s;
  for (int i = 0; i < v->rank; ++i) s += (i ? "x" : "") + std::to_string(v->dims[i]);
  return s;
}

std::size_t element_count(const matvar_t* v) {
  std::size_t n = 1;
  for (int i = 0; i < v->rank; ++i) n *= v->dims[i];
  return n;
}

// Whether a variable is a vector (or a scalar): at most one dimension above 1.
bool is_vector(const matvar_t* v) {
  int above_one = 0;
  for (int i = 0; i < v->rank; ++i) above_one += v->dims[i] > 1;
  return above_one <= 1;
}

const char* class_name(matio_classes c) {
  switch (c) {
    case MAT_C_CELL: return "a cell array";
    case MAT_C_STRUCT: return "a struct";
    case MAT_C_OBJECT: return "an object";
    case MAT_C_CHAR: return "a char array";
    case MAT_C_SPARSE: return "a sparse matrix";
    case MAT_C_FUNCTION: return "a function handle";
    case MAT_C_OPAQUE: return "an opaque object";
    default: return "numeric";
  }
}

bool is_numeric(matio_classes c) {
  switch (c) {
    case MAT_C_DOUBLE: case MAT_C_SINGLE: case MAT_C_INT8: case MAT_C_UINT8: case MAT_C_INT16:
    case MAT_C_UINT16: case MAT_C_INT32: case MAT_C_UINT32: case MAT_C_INT64: case MAT_C_UINT64:
      return true;
    default:
      return false;
  }
}

template <class T>
std::vector<double> as_doubles(const void* data, std::size_t n) {
  const T* p = static_cast<const T*>(data);
  return std::vector<double>(p, p + n);
}

// The values of a real numeric vector, converted to double.
std::vector<double> numeric_values(const matvar_t* v) {
  const std::size_t n = element_count(v);
  switch (v->class_type) {
    case MAT_C_DOUBLE: return as_doubles<double>(v->data, n);
    case MAT_C_SINGLE: return as_doubles<float>(v->data, n);
    case MAT_C_INT8: return as_doubles<mat_int8_t>(v->data, n);
    case MAT_C_UINT8: return as_doubles<mat_uint8_t>(v->data, n);
    case MAT_C_INT16: return as_doubles<mat_int16_t>(v->data, n);
    case MAT_C_UINT16: return as_doubles<mat_uint16_t>(v->data, n);
    case MAT_C_INT32: return as_doubles<mat_int32_t>(v->data, n);
    case MAT_C_UINT32: return as_doubles<mat_uint32_t>(v->data, n);
    case MAT_C_INT64: return as_doubles<mat_int64_t>(v->data, n);
    case MAT_C_UINT64: return as_doubles<mat_uint64_t>(v->data, n);
    default: return {};
  }
}

// One variable or struct field (shown as `shown`) as the column `name`, or unusable.
void add_column(const matvar_t* v, const std::string& name, const std::string& shown, MatColumns* out) {
  const std::string what = shown + " (" + dims_text(v) + ")";
  std::string reason;
  if (!is_numeric(v->class_type)) reason = what + " is " + class_name(v->class_type);
  else if (v->isComplex) reason = what + " is complex";
  else if (v->isLogical) reason = what + " is logical";
  else if (!is_vector(v)) reason = what + " is a matrix: a column is a vector";
  else if (element_count(v) == 0) reason = what + " is empty";
  else if (v->data == nullptr) reason = what + ": its data cannot be read";
  if (reason.empty()) out->columns.push_back({name, numeric_values(v)});
  else out->unusable.push_back({name, reason});
}

[[noreturn]] void refuse(const std::string& path, const std::string& problem) {
  throw InputError(path + ": " + problem +
                   " (a run .mat holds real numeric vectors named like the CSV columns, or one struct of "
                   "them: docs/formats.md)");
}

void read_struct_fields(const std::string& path, matvar_t* s, MatColumns* out) {
  if (element_count(s) != 1) refuse(path, std::string("variable ") + s->name + " is a " + dims_text(s) + " struct array");
  const unsigned n = Mat_VarGetNumberOfFields(s);
  char* const* fields = Mat_VarGetStructFieldnames(s);
  for (unsigned i = 0; i < n; ++i) {
    matvar_t* f = Mat_VarGetStructFieldByName(s, fields[i], 0);
    const std::string shown = "field " + std::string(s->name) + "." + fields[i];
    if (f == nullptr) refuse(path, shown + " cannot be read");
    add_column(f, fields[i], shown, out);
  }
}

// Vectors of another length than the time (or phase) vector -- or, without one, than the
// first vector -- become unusable.
void check_lengths(const std::string& path, MatColumns* m) {
  if (m->columns.empty()) refuse(path, "no numeric vector found");
  const MatColumn* reference = &m->columns.front();
  for (const MatColumn& c : m->columns)
    if (c.name.rfind("time", 0) == 0 || c.name.rfind("phase", 0) == 0) {
      reference = &c;
      break;
    }
  const std::string reference_name = reference->name;
  const std::size_t n = reference->values.size();
  std::vector<MatColumn> kept;
  for (MatColumn& c : m->columns) {
    if (c.values.size() == n) kept.push_back(std::move(c));
    else
      m->unusable.push_back({c.name, c.name + " has " + std::to_string(c.values.size()) + " samples, " +
                                         reference_name + " has " + std::to_string(n)});
  }
  m->columns = std::move(kept);
}

}  // namespace

bool is_mat_file(const std::string& path) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".mat";
}

MatColumns read_mat_columns(const std::string& path) {
  static const int log_ready = Mat_LogInitFunc("indicial", capture_matio_log);
  (void)log_ready;
  matio_last_message.clear();
  MatFile mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!mat)
    throw InputError(path, 0, "cannot open as a MAT-file (v5 or v7.3)" +
                                  (matio_last_message.empty() ? std::string() : ": " + matio_last_message));
  MatColumns out;
  out.version = Mat_GetVersion(mat.get()) == MAT_FT_MAT73 ? "v7.3" : Mat_GetVersion(mat.get()) == MAT_FT_MAT5 ? "v5" : "v4";
  std::vector<MatVar> structs;
  while (true) {
    MatVar info(Mat_VarReadNextInfo(mat.get()));
    if (!info) break;
    MatVar v(Mat_VarRead(mat.get(), info->name));
    if (!v) refuse(path, std::string("variable ") + info->name + " cannot be read");
    if (v->class_type == MAT_C_STRUCT) structs.push_back(std::move(v));
    else add_column(v.get(), v->name, std::string("variable ") + v->name, &out);
  }
  if (out.columns.empty()) {
    if (structs.size() > 1) {
      std::string names;
      for (const MatVar& s : structs) names += (names.empty() ? "" : ", ") + std::string(s->name);
      refuse(path, "several structs (" + names + ") and no top-level vectors: which run is meant? Save one per file");
    }
    if (structs.size() == 1) {
      out.unusable.clear();  // the struct holds the run; top-level leftovers are not columns
      read_struct_fields(path, structs.front().get(), &out);
    }
  } else {
    for (const MatVar& s : structs) out.notes.push_back(std::string("ignored struct ") + s->name + " (the file has top-level vectors)");
  }
  check_lengths(path, &out);
  return out;
}

}  // namespace indicial
