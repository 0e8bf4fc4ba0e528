// Merging separately fitted coefficients into one model set. See
// indicial/fitter/model_merge.hpp.
#include "indicial/fitter/model_merge.hpp"

#include <algorithm>
#include <cstdio>
#include <string>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

std::string deg(double rad) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", rad * kRadToDeg);
  return buf;
}

// Refuses a field that differs between the first part and `part`.
void same_field(const NamedModelSet& first, const NamedModelSet& part, const char* field, const std::string& a,
                const std::string& b) {
  if (a == b) return;
  throw InputError(part.origin, 0, std::string("cannot merge: ") + field + " is " + b + " here but " + a + " in " +
                                       first.origin);
}

}  // namespace

ModelMerge merge_model_sets(const std::vector<NamedModelSet>& parts) {
  if (parts.empty()) throw InputError("merge", 0, "nothing to merge");
  const NamedModelSet& first = parts.front();
  ModelMerge out;
  out.model = *first.model;
  out.model.n_coefficients = 0;
  int total = 0;
  for (const NamedModelSet& p : parts) total += p.model->n_coefficients;
  if (total > DefaultCapacity::max_coefficients) {
    throw InputError(parts.back().origin, 0, "cannot merge: " + std::to_string(total) +
                                                 " coefficients; the runtime (indicial::DefaultCapacity) holds at most " +
                                                 std::to_string(DefaultCapacity::max_coefficients));
  }
  for (const NamedModelSet& p : parts) {
    const ModelSet<double, FitCapacity>& m = *p.model;
    same_field(first, p, "the axis", axis_name(first.model->axis), axis_name(m.axis));
    same_field(first, p, "reference_length_m", format_double(first.model->reference_length_m),
               format_double(m.reference_length_m));
    same_field(first, p, "alpha0", deg(first.model->alpha0_rad) + " deg", deg(m.alpha0_rad) + " deg");
    same_field(first, p, "the reference airspeed", format_double(first.model->airspeed_mps) + " m/s",
               format_double(m.airspeed_mps) + " m/s");
    for (int c = 0; c < m.n_coefficients; ++c) {
      for (int k = 0; k < out.model.n_coefficients; ++k) {
        if (detail::names_equal(out.model.coefficients[k].name, m.coefficients[c].name)) {
          throw InputError(p.origin, 0, std::string("cannot merge: coefficient ") + m.coefficients[c].name +
                                            " is already in an earlier file");
        }
      }
      out.model.coefficients[out.model.n_coefficients++] = m.coefficients[c];
    }
    out.model.x_min_rad = std::max(out.model.x_min_rad, m.x_min_rad);
    out.model.x_max_rad = std::min(out.model.x_max_rad, m.x_max_rad);
  }
  if (!(out.model.x_min_rad < out.model.x_max_rad)) {
    throw InputError(parts.back().origin, 0, "cannot merge: the envelopes do not overlap (their intersection is [" +
                                                 deg(out.model.x_min_rad) + ", " + deg(out.model.x_max_rad) + "] deg)");
  }
  for (const NamedModelSet& p : parts) {
    if (p.model->x_min_rad < out.model.x_min_rad || p.model->x_max_rad > out.model.x_max_rad) {
      out.warnings.push_back(p.origin + ": envelope [" + deg(p.model->x_min_rad) + ", " + deg(p.model->x_max_rad) +
                             "] deg shrinks to the common [" + deg(out.model.x_min_rad) + ", " +
                             deg(out.model.x_max_rad) + "] deg in the merged model");
    }
  }
  return out;
}

std::string coef_file_text(const ModelSet<double, FitCapacity>& model, const std::string& origin) {
  // The writer needs a caller buffer; grow it until the text fits.
  std::vector<char> buffer(16384);
  for (int attempt = 0; attempt < 8; ++attempt) {
    std::size_t n = 0;
    const WriteStatus st = write_coef_file(model, buffer.data(), buffer.size(), &n);
    if (st == WriteStatus::ok) return std::string(buffer.data(), n);
    if (st != WriteStatus::buffer_too_small) {
      ParseDiagnostic diag;
      validate_model_set(model, &diag);
      throw InputError(origin, 0, std::string("the model cannot be written as a coefficient file (") + to_string(st) +
                                      ": " + diag.reason + ")");
    }
    buffer.resize(buffer.size() * 4);
  }
  throw InputError(origin, 0, "the model's coefficient file is unreasonably large");
}

}  // namespace indicial
