// numerics/covariance.hpp -- the covariance of a least-squares estimate, in one place.
//
// What it is for
// --------------
// At a least-squares estimate with Jacobian J (residuals v, N samples), the Cramer-Rao bounds
// come from the information matrix A = J'J:
//   white    C_w = s^2 A^+                       s^2 = |v|^2 / N, white Gaussian residuals
//   colored  C_c = A^+ M A^+                     M = sum_k R(k) (J_t' J_{t+k} + transpose),
//                                                R(k) the residuals' autocorrelation, |k| <= lag
// (the sandwich estimator for residuals correlated over `lag` samples within each run). A^+ is
// the pseudo-inverse on A's numerical range, so a parameter the data cannot determine gets no
// finite variance: it is reported in the null space instead. Covariance holds all of it:
// the rank-revealing analysis of A (Compute), the white and colored matrices, the sandwich's
// middle M (correlated_middle), the choice of its lag (correlation_lag) and the full-rank
// linear case of the equation error (linear_least_squares). The Levenberg-Marquardt solver
// (numerics/levenberg_marquardt.hpp) uses it every iteration for its step-size test in units
// of the bounds; the output-error fit uses it at the estimate; the equation error uses
// linear_least_squares, the stepwise regression's colored partial F correlated_middle.
//
// Modelled on Ceres' include/ceres/covariance.h: a class with its own Options (IsValid), a
// Compute step, then queries. Unlike Ceres it takes a dense A (the fitter's problems have at
// most a few dozen parameters) and returns a pseudo-inverse rather than failing on a rank
// deficiency, because naming the unidentifiable parameters is part of the answer.
//
// How A is analysed: scaled to unit diagonal (D^-1 A D^-1, D = sqrt(diag A)) so that the rank
// decision judges collinearity, not units; eigen-decomposed; eigenvalues below
// sv_cutoff^2 * (largest) are the null space (sv_cutoff is on the singular values of the scaled
// J); a parameter whose squared share in a null-space eigenvector exceeds null_space_share, or
// whose column of J is zero, is in the null space.
//
// Warnings
// --------
// 1. No heap allocation after construction: Compute reuses the workspace sized by the
//    constructor (its symmetric eigen-decomposition is Eigen's SelfAdjointEigenSolver step by
//    step with the Householder workspace preallocated, bit-identical to it; covariance_test.cpp
//    checks both). white() and colored() return new matrices (they allocate; called once per
//    fit).
// 2. A must be symmetric positive semi-definite (J'J); only its lower triangle is read by the
//    eigen-decomposition.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace indicial::numerics {

class Covariance {
 public:
  struct Options {
    // Rank decision: singular values of the unit-diagonal-scaled J below sv_cutoff times the
    // largest count as zero (Ceres: min_reciprocal_condition_number, on singular values).
    double sv_cutoff = 1e-8;
    // A parameter is named in the null space when its squared component in a null-space
    // eigenvector exceeds this share (the eigenvectors have unit norm).
    double null_space_share = 0.01;
    bool IsValid(std::string* error) const;
  };

  // Workspace for num_parameters x num_parameters information matrices.
  Covariance(int num_parameters, const Options& options);

  // Analyses A = J'J (size num_parameters). Returns false, and does nothing, when the options
  // are invalid or A has the wrong size.
  bool Compute(const Eigen::MatrixXd& information);

  // After Compute: A's pseudo-inverse on its numerical range, its rank, the null space.
  const Eigen::MatrixXd& pseudo_inverse() const { return pinv_; }
  int rank() const { return rank_; }
  bool in_null_space(int i) const { return in_null_space_[static_cast<std::size_t>(i)]; }

  // s^2 A^+ and A^+ M A^+ (M from correlated_middle).
  Eigen::MatrixXd white(double residual_variance) const;
  Eigen::MatrixXd colored(const Eigen::MatrixXd& middle) const;

  // M = sum_{|k| <= lag} R(k) G_t' G_{t+k} over the runs (rows starts[s] .. starts[s+1]-1 of G
  // and v; starts ends with the row count), R(k) = sum v_t v_{t+k} / N.
  static Eigen::MatrixXd correlated_middle(const Eigen::MatrixXd& G, const Eigen::VectorXd& v,
                                           const std::vector<std::size_t>& starts, int lag);

  // How far residuals are correlated. fixed: max_lag. automatic: the window extends while the
  // sample autocorrelation |R(k)| exceeds 2 R(0) / sqrt(N), twice its standard deviation for
  // white residuals (so white residuals get almost the white bounds), at most max_lag.
  enum class LagRule { fixed, automatic };
  static int correlation_lag(const Eigen::VectorXd& v, const std::vector<std::size_t>& starts,
                             int max_lag, LagRule rule);

  // The covariances of a FULL-RANK linear least-squares estimate (the equation error and the
  // stepwise regression: z = X b + v, n rows, p < n columns), from the thin SVD of the
  // column-scaled regressors X D^-1 = U S V' (D = diag(column_scale), the column norms):
  //   (X'X)^-1 = D^-1 V S^-2 V' D^-1
  //   white    s^2 (X'X)^-1,            s^2 = sse / (n - p)
  //   colored  (X'X)^-1 M (X'X)^-1,     M = correlated_middle(X, residual, starts, lag) n / (n - p)
  // (the N / (N - p) factor, like s^2's, makes the colored bound reduce to the white one for
  // white residuals). The caller has checked the rank (it names the dependent terms); no
  // pseudo-inverse here. Allocates (once per regression).
  struct LinearEstimate {
    Eigen::MatrixXd white;
    Eigen::MatrixXd colored;
  };
  static LinearEstimate linear_least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& column_scale,
                                             const Eigen::VectorXd& singular_values, const Eigen::MatrixXd& V,
                                             const Eigen::VectorXd& residual, double sse,
                                             const std::vector<std::size_t>& starts, int lag);

 private:
  void decompose();  // eigen-decomposition of scaled_ into eigenvectors_ / eigenvalues_

  Options options_;
  Eigen::Index n_ = 0;
  Eigen::VectorXd d_, dinv_, eigenvalues_, subdiagonal_, householder_, workspace_;
  Eigen::MatrixXd scaled_, eigenvectors_, pin_, pinv_;
  std::vector<bool> in_null_space_;
  int rank_ = 0;
};

}  // namespace indicial::numerics
