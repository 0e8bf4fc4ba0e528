// indicial/fitter/model_merge.hpp -- one model set from separately fitted coefficients.
//
// What it is for
// --------------
// The runtime steps every coefficient of a ModelSet from one Predictor (out.value[0] = CL,
// [1] = Cm). `indicial fit` on an experiment with `coefficients = ["CL", "Cm"]` fits each
// coefficient separately and assembles them here; `indicial coef merge A.coef B.coef` does
// the same with files fitted apart. The checks are those that make the merged model mean what
// each part meant: one axis, reference length, alpha0 and reference airspeed; distinct
// coefficient names; an envelope every part was fitted on.
//
// Usage
// -----
//   indicial::ModelMerge m = indicial::merge_model_sets({{"CL.coef", &cl}, {"Cm.coef", &cm}});
//   for (const auto& w : m.warnings) std::fprintf(stderr, "indicial: warning: %s\n", w.c_str());
//   std::string text = indicial::coef_file_text(m.model, "AB.coef");
//
// Warnings
// --------
// 1. The envelope is the intersection of the parts' envelopes: each part is valid only where
//    it was fitted. When it is smaller than a part's own envelope a warning says so; when it is
//    empty the merge is refused.
// 2. Equality of the scalar fields is exact (a .coef file round-trips doubles), so two fits of
//    one experiment always merge and 17.667762 vs 17.6678 never does.
// 3. The total number of coefficients must fit indicial::DefaultCapacity::max_coefficients:
//    the merged file is for the default runtime.
#pragma once

#include <string>
#include <vector>

#include "indicial/model.hpp"

namespace indicial {

// One input of a merge: where it came from (named in messages) and the model.
struct NamedModelSet {
  std::string origin;
  const ModelSet<double, FitCapacity>* model = nullptr;
};

struct ModelMerge {
  ModelSet<double, FitCapacity> model;
  std::vector<std::string> warnings;  // one line each (a shrunk envelope)
};

// Merges the coefficients of `parts`, in order. Throws InputError naming the offending
// origin(s), the field and both values when the parts disagree, when a coefficient repeats,
// when the envelopes do not overlap, or when there are more coefficients than
// DefaultCapacity::max_coefficients.
ModelMerge merge_model_sets(const std::vector<NamedModelSet>& parts);

// The model set as coefficient-file text (the runtime's writer). Throws InputError naming
// `origin` if the writer refuses the model.
std::string coef_file_text(const ModelSet<double, FitCapacity>& model, const std::string& origin);

}  // namespace indicial
