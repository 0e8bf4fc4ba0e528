// numerics/covariance.cpp -- see covariance.hpp.
#include "numerics/covariance.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace indicial::numerics {

bool Covariance::Options::IsValid(std::string* error) const {
  auto fail = [&](const char* what) {
    if (error) *error = what;
    return false;
  };
  if (!(sv_cutoff > 0.0 && sv_cutoff < 1.0)) return fail("sv_cutoff must be in (0, 1)");
  if (!(null_space_share > 0.0 && null_space_share < 1.0))
    return fail("null_space_share must be in (0, 1)");
  return true;
}

Covariance::Covariance(int num_parameters, const Options& options)
    : options_(options), n_(std::max(num_parameters, 0)) {
  for (Eigen::VectorXd* v : {&d_, &dinv_, &eigenvalues_, &workspace_}) v->resize(n_);
  subdiagonal_.resize(std::max<Eigen::Index>(n_ - 1, 0));
  householder_.resize(std::max<Eigen::Index>(n_ - 1, 0));
  for (Eigen::MatrixXd* m : {&scaled_, &eigenvectors_, &pin_, &pinv_}) m->resize(n_, n_);
  in_null_space_.assign(static_cast<std::size_t>(n_), false);
}

// Eigen 3.4's SelfAdjointEigenSolver::compute(A, ComputeEigenvectors), step by step, with the
// Householder workspace preallocated: SelfAdjointEigenSolver allocates that vector on every
// call (HouseholderSequence::evalTo(dst)). Same operations in the same order, so the results
// are bit-identical (covariance_test.cpp compares them on random matrices).
void Covariance::decompose() {
  using Eigen::Lower;
  if (n_ == 1) {
    eigenvectors_ = scaled_;
    eigenvalues_(0) = eigenvectors_(0, 0);
    eigenvectors_.setOnes(1, 1);
    return;
  }
  eigenvectors_ = scaled_.triangularView<Lower>();
  double scale = eigenvectors_.cwiseAbs().maxCoeff();
  if (scale == 0.0) scale = 1.0;
  eigenvectors_.triangularView<Lower>() /= scale;
  Eigen::internal::tridiagonalization_inplace(eigenvectors_, householder_);
  eigenvalues_ = eigenvectors_.diagonal();
  subdiagonal_ = eigenvectors_.diagonal<-1>();
  Eigen::HouseholderSequence<Eigen::MatrixXd, Eigen::VectorXd>(eigenvectors_, householder_)
      .setLength(n_ - 1)
      .setShift(1)
      .evalTo(eigenvectors_, workspace_);
  Eigen::internal::computeFromTridiagonal_impl(
      eigenvalues_, subdiagonal_, Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>::m_maxIterations,
      true, eigenvectors_);
  eigenvalues_ *= scale;
}

bool Covariance::Compute(const Eigen::MatrixXd& A) {
  if (!options_.IsValid(nullptr) || A.rows() != n_ || A.cols() != n_ || n_ == 0) return false;
  const Eigen::Index p = n_;
  rank_ = 0;
  std::fill(in_null_space_.begin(), in_null_space_.end(), false);
  d_ = A.diagonal().cwiseMax(0.0).cwiseSqrt();
  for (Eigen::Index i = 0; i < p; ++i) dinv_(i) = d_(i) > 0.0 ? 1.0 / d_(i) : 0.0;
  scaled_ = dinv_.asDiagonal() * A * dinv_.asDiagonal();
  // Why: a parameter whose column of J is exactly zero has no information at all; give it a
  // zero diagonal so the eigen-analysis puts it (alone) in the null space.
  for (Eigen::Index i = 0; i < p; ++i)
    if (d_(i) == 0.0) scaled_(i, i) = 0.0;
  decompose();
  const double emax = eigenvalues_(p - 1);  // ascending
  // Cut-off on singular values of the scaled J = sqrt(eigenvalues of the scaled A).
  const double cut = options_.sv_cutoff * options_.sv_cutoff * emax;
  pin_.setZero();
  for (Eigen::Index k = 0; k < p; ++k) {
    const auto vk = eigenvectors_.col(k);
    if (eigenvalues_(k) > cut && emax > 0.0) {
      pin_.noalias() += vk.lazyProduct(vk.transpose()) / eigenvalues_(k);
      ++rank_;
    } else {
      for (Eigen::Index i = 0; i < p; ++i)
        if (vk(i) * vk(i) > options_.null_space_share)
          in_null_space_[static_cast<std::size_t>(i)] = true;
    }
  }
  for (Eigen::Index i = 0; i < p; ++i)
    if (d_(i) == 0.0) in_null_space_[static_cast<std::size_t>(i)] = true;
  pinv_ = dinv_.asDiagonal() * pin_ * dinv_.asDiagonal();
  return true;
}

Eigen::MatrixXd Covariance::white(double residual_variance) const {
  return residual_variance * pinv_;
}

Eigen::MatrixXd Covariance::colored(const Eigen::MatrixXd& middle) const {
  return pinv_ * middle * pinv_;
}

Eigen::MatrixXd Covariance::correlated_middle(const Eigen::MatrixXd& G, const Eigen::VectorXd& v,
                                              const std::vector<std::size_t>& starts, int lag) {
  const Eigen::Index p = G.cols();
  const double n = static_cast<double>(v.size());
  Eigen::MatrixXd mid = Eigen::MatrixXd::Zero(p, p);
  for (int k = 0; k <= lag; ++k) {
    double rk = 0.0;
    Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(p, p);
    for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
      const auto b = static_cast<Eigen::Index>(starts[s]);
      const auto len = static_cast<Eigen::Index>(starts[s + 1] - starts[s]) - k;
      if (len <= 0) continue;
      rk += v.segment(b, len).dot(v.segment(b + k, len));
      cross.noalias() += G.middleRows(b, len).transpose() * G.middleRows(b + k, len);
    }
    rk /= n;
    // R(-k) = R(k): the pair sums for +k and -k are transposes of each other.
    if (k == 0) mid += rk * cross;
    else mid += rk * (cross + cross.transpose());
  }
  return mid;
}

int Covariance::correlation_lag(const Eigen::VectorXd& v, const std::vector<std::size_t>& starts,
                                int max_lag, LagRule rule) {
  const int cap = std::max(0, max_lag);
  if (rule == LagRule::fixed) return cap;
  const double n = static_cast<double>(v.size());
  double r0 = v.squaredNorm() / n;
  if (!(r0 > 0.0)) return 0;
  const double threshold = 2.0 * r0 / std::sqrt(n);
  for (int k = 1; k <= cap; ++k) {
    double rk = 0.0;
    for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
      for (std::size_t i = starts[s]; i + static_cast<std::size_t>(k) < starts[s + 1]; ++i)
        rk += v[static_cast<Eigen::Index>(i)] * v[static_cast<Eigen::Index>(i) + k];
    }
    rk /= n;
    if (std::abs(rk) < threshold) return k - 1;
  }
  return cap;
}

Covariance::LinearEstimate Covariance::linear_least_squares(const Eigen::MatrixXd& X,
                                                           const Eigen::VectorXd& column_scale,
                                                           const Eigen::VectorXd& singular_values,
                                                           const Eigen::MatrixXd& V, const Eigen::VectorXd& residual,
                                                           double sse, const std::vector<std::size_t>& starts,
                                                           int lag) {
  const Eigen::Index n = X.rows(), p = X.cols();
  const Eigen::VectorXd inv_s2 = singular_values.cwiseInverse().cwiseAbs2();
  // (X'X)^-1 = D^-1 V S^-2 V' D^-1
  const Eigen::MatrixXd Vd = column_scale.cwiseInverse().asDiagonal() * V;
  const Eigen::MatrixXd xtx_inv = Vd * inv_s2.asDiagonal() * Vd.transpose();
  const double s2 = sse / static_cast<double>(n - p);
  LinearEstimate c;
  c.white = s2 * xtx_inv;
  // The sandwich with R(k) normalised by N; scale by N / (N - p) like s^2 so that the colored
  // bound reduces to the white one for white residuals.
  const Eigen::MatrixXd mid = correlated_middle(X, residual, starts, lag) *
                              (static_cast<double>(n) / static_cast<double>(n - p));
  c.colored = xtx_inv * mid * xtx_inv;
  return c;
}

}  // namespace indicial::numerics
