// experiment_stepwise_colored -- the measured tables of docs/validation.md, "Stepwise under
// colored residuals" (24 seeds each, minutes): not a test (tests/test_fit_stepwise_colored.cpp
// checks a few seeds in ctest), an experiment whose printed rows are copied into the doc.
//
//   build/bench/experiment_stepwise_colored table      # spurious / missed terms, white vs colored F
//   build/bench/experiment_stepwise_colored pse-pick   # does the final pick by least PSE keep spurious terms
#include <cstdint>
#include <cstring>
#include <iostream>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "stepwise_colored_data.hpp"

using namespace indicial;
using namespace indicial::testing;

namespace {

void print_line(const std::string& line) { std::cout << line << "\n"; }

// The measured table of docs/validation.md ("Stepwise under colored residuals"): 24 seeds,
// AR(1) 0.8 and white noise, the regression and the output-error stepwise.
void measured_table() {
  std::vector<std::uint64_t> seeds;
  for (std::uint64_t s = 8001; s <= 8024; ++s) seeds.push_back(s);
  for (const auto& [label, noise] : {std::pair<std::string, NoiseModel>{"AR(1) phi 0.8", ar1()},
                                     std::pair<std::string, NoiseModel>{"white", NoiseModel{}}}) {
    for (StepwiseRefinement ref : {StepwiseRefinement::none, StepwiseRefinement::output_error}) {
      const Rates r = measure(seeds, noise, ref, print_line);
      std::cout << "| " << label << " | " << std::string(ref == StepwiseRefinement::none ? "regression" : "output-error stepwise")
                   << " | " << r.seeds << " | " << r.spurious_white << " | " << r.spurious_colored << " | "
                   << r.missed_white << " | " << r.missed_colored << " |\n";
    }
  }
}

// Whether the stepwise's final pick by least PSE matters under colored residuals (its penalty
// sigma_max^2 p / N counts N white samples). From each seed's log: the model at the end of the
// F-test path, the pick by PSE, and the picks by PSE with the penalty scaled by kappa = 2, 4, 9
// (an effective sample size N / kappa: AR(1) 0.8 gives (1 + 0.8) / (1 - 0.8) = 9 at most),
// SSE / N recovered from each step's PSE. Counted: a spurious term kept, a true term missed.
void pse_pick() {
  const std::vector<double> kappas = {1.0, 2.0, 4.0, 9.0};
  for (const auto& [label, noise] : {std::pair<std::string, NoiseModel>{"AR(1) phi 0.8", ar1()},
                                     std::pair<std::string, NoiseModel>{"white", NoiseModel{}}}) {
    int seeds = 0, path_spurious = 0, path_missed = 0, pick_differs = 0;
    double r2_sum = 0.0;
    std::vector<int> spur(kappas.size(), 0), miss(kappas.size(), 0);
    for (std::uint64_t seed = 8001; seed <= 8024; ++seed) {
      const FitResult r = fit_experiment(noisy_experiment(seed, noise), FitOptions{});
      const StepwiseResult& s = r.equation_error.stepwise;
      ++seeds;
      r2_sum += r.equation_error.r_squared;
      // The model after each step, and the F path's last model.
      std::vector<std::set<std::string>> models = {{}};
      for (const StepwiseStep& st : s.steps) {
        std::set<std::string> m = models.back();
        if (st.action == StepwiseAction::entered) m.insert(st.term);
        else m.erase(st.term);
        models.push_back(m);
      }
      path_spurious += spurious(models.back()) ? 1 : 0;
      path_missed += complete(models.back()) ? 0 : 1;
      const double n = static_cast<double>(s.n_samples);
      for (std::size_t k = 0; k < kappas.size(); ++k) {
        double best = s.sigma_max_squared;  // the empty model: SSE / N = z.z / N >= sigma_max^2
        std::size_t at = 0;
        for (std::size_t i = 0; i < s.steps.size(); ++i) {
          const double p = static_cast<double>(s.steps[i].n_terms);
          const double sse_n = s.steps[i].pse - s.sigma_max_squared * p / n;
          const double pse = sse_n + kappas[k] * s.sigma_max_squared * p / n;
          if (pse < best) {
            best = pse;
            at = i + 1;
          }
        }
        spur[k] += spurious(models[at]) ? 1 : 0;
        if (k + 1 == kappas.size() && spurious(models[at])) {
          std::string path;
          for (const StepwiseStep& st : s.steps)
            path += (st.action == StepwiseAction::entered ? " +" : " -") + st.term + " (F " +
                    std::to_string(st.partial_f).substr(0, 6) + ", white " + std::to_string(st.partial_f_white).substr(0, 6) + ")";
          std::cout << label << " seed " << seed << ", spurious at kappa " << kappas[k] << ":" << path << "\n";
        }
        miss[k] += complete(models[at]) ? 0 : 1;
        if (k == 0) {
          if (models[at] != std::set<std::string>(s.selected.begin(), s.selected.end()))  // the fitter's pick
            std::cout << label << " seed " << seed << ": the PSE pick recomputed here is not the fitter's\n";
          pick_differs += models[at] == models.back() ? 0 : 1;
        }
      }
    }
    std::string row = "| " + label + " | " + std::to_string(seeds) + " | " + std::to_string(path_spurious) + " / " +
                      std::to_string(path_missed) + " | " + std::to_string(pick_differs);
    for (std::size_t k = 0; k < kappas.size(); ++k)
      row += " | " + std::to_string(spur[k]) + " / " + std::to_string(miss[k]);
    row += " |";
    std::cout << row << " mean R^2 " << r2_sum / seeds << "\n";
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::string what = argc > 1 ? argv[1] : "";
  if (what == "table") {
    measured_table();
  } else if (what == "pse-pick") {
    pse_pick();
  } else {
    std::cerr << "usage: " << argv[0] << " table | pse-pick\n";
    return 1;
  }
  return 0;
}
