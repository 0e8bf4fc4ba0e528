// The covariance of a least-squares estimate (fitter/src/numerics/covariance.hpp): its
// eigen-decomposition is bit-identical to Eigen's SelfAdjointEigenSolver (which it replaces to
// avoid an allocation per call), the pseudo-inverse equals the inverse at full rank, a
// collinear or empty column lands in the null space, options are validated, and the
// sandwich's middle reduces to J'J R(0) at lag 0.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>

#include <cstring>
#include <string>
#include <vector>

#include "numerics/covariance.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using indicial::numerics::Covariance;

namespace {
// A deterministic J (no rand(): reproducible on every machine) with column scales spread over
// six decades, so the unit-diagonal scaling matters.
Eigen::MatrixXd jacobian(int rows, int cols, int seed) {
  Eigen::MatrixXd J(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j)
      J(i, j) = std::sin(0.37 * (i + 1) * (j + 1) + seed) * std::pow(10.0, (j % 7) - 3);
  return J;
}
}  // namespace

TEST_CASE("covariance: the eigen-analysis matches SelfAdjointEigenSolver bit for bit") {
  // Compute's pseudo-inverse rebuilt from Eigen's own solver on the same scaled matrix.
  for (int n = 1; n <= 14; ++n) {
    for (int seed = 0; seed < 3; ++seed) {
      const Eigen::MatrixXd J = jacobian(60, n, seed);
      const Eigen::MatrixXd A = J.transpose() * J;
      Covariance c(n, Covariance::Options{});
      REQUIRE(c.Compute(A));
      const Eigen::VectorXd d = A.diagonal().cwiseMax(0.0).cwiseSqrt();
      const Eigen::VectorXd dinv = d.cwiseInverse();
      const Eigen::MatrixXd As = dinv.asDiagonal() * A * dinv.asDiagonal();
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(As);
      const double emax = es.eigenvalues()(n - 1);
      Eigen::MatrixXd pin = Eigen::MatrixXd::Zero(n, n);
      for (int k = 0; k < n; ++k) {
        const Eigen::VectorXd vk = es.eigenvectors().col(k);
        if (es.eigenvalues()(k) > 1e-16 * emax) pin += vk * vk.transpose() / es.eigenvalues()(k);
      }
      const Eigen::MatrixXd want = dinv.asDiagonal() * pin * dinv.asDiagonal();
      INFO("n = " << n << ", seed = " << seed);
      CHECK(std::memcmp(want.data(), c.pseudo_inverse().data(), sizeof(double) * static_cast<std::size_t>(n * n)) == 0);
    }
  }
}

TEST_CASE("covariance: full rank gives the inverse, white and colored scale it") {
  const Eigen::MatrixXd J = jacobian(40, 4, 1);
  const Eigen::MatrixXd A = J.transpose() * J;
  Covariance c(4, Covariance::Options{});
  REQUIRE(c.Compute(A));
  CHECK(c.rank() == 4);
  for (int i = 0; i < 4; ++i) CHECK_FALSE(c.in_null_space(i));
  const Eigen::MatrixXd I = c.pseudo_inverse() * A;
  CHECK((I - Eigen::MatrixXd::Identity(4, 4)).cwiseAbs().maxCoeff() < 1e-9);
  CHECK((c.white(2.0) - 2.0 * c.pseudo_inverse()).cwiseAbs().maxCoeff() == 0.0);
  // The sandwich with M = A is A^+ A A^+ = A^+ at full rank.
  CHECK((c.colored(A) - c.pseudo_inverse()).cwiseAbs().maxCoeff() <
        1e-9 * c.pseudo_inverse().cwiseAbs().maxCoeff());
}

TEST_CASE("covariance: collinear and empty columns are the null space") {
  Eigen::MatrixXd J = jacobian(40, 5, 2);
  J.col(3) = 2.5 * J.col(1);  // collinear pair
  J.col(4).setZero();         // no information at all
  Covariance c(5, Covariance::Options{});
  REQUIRE(c.Compute(J.transpose() * J));
  CHECK(c.rank() == 3);
  CHECK(c.in_null_space(1));
  CHECK(c.in_null_space(3));
  CHECK(c.in_null_space(4));
  CHECK_FALSE(c.in_null_space(0));
  CHECK_FALSE(c.in_null_space(2));
}

TEST_CASE("covariance: options are validated, a wrong size is refused") {
  Covariance::Options o;
  std::string why;
  CHECK(o.IsValid(&why));
  o.sv_cutoff = 1.5;
  CHECK_FALSE(o.IsValid(&why));
  CHECK(why.find("sv_cutoff") != std::string::npos);
  o = Covariance::Options{};
  o.null_space_share = 0.0;
  CHECK_FALSE(o.IsValid(&why));
  CHECK(why.find("null_space_share") != std::string::npos);
  Covariance bad(2, o);
  CHECK_FALSE(bad.Compute(Eigen::MatrixXd::Identity(2, 2)));
  Covariance c(3, Covariance::Options{});
  CHECK_FALSE(c.Compute(Eigen::MatrixXd::Identity(2, 2)));
}

TEST_CASE("covariance: the sandwich's middle and the lag window") {
  const Eigen::MatrixXd G = jacobian(30, 3, 3);
  Eigen::VectorXd v(30);
  for (int i = 0; i < 30; ++i) v(i) = std::cos(1.7 * i);
  const std::vector<std::size_t> starts{0, 12, 30};
  // Lag 0: M = R(0) G'G with R(0) = |v|^2 / N.
  const Eigen::MatrixXd m0 = Covariance::correlated_middle(G, v, starts, 0);
  const Eigen::MatrixXd want = (v.squaredNorm() / 30.0) * (G.transpose() * G);
  CHECK((m0 - want).cwiseAbs().maxCoeff() < 1e-12 * want.cwiseAbs().maxCoeff());
  // Lag 1 is symmetric and differs from lag 0.
  const Eigen::MatrixXd m1 = Covariance::correlated_middle(G, v, starts, 1);
  CHECK((m1 - m1.transpose()).cwiseAbs().maxCoeff() < 1e-12 * m1.cwiseAbs().maxCoeff());
  CHECK((m1 - m0).cwiseAbs().maxCoeff() > 0.0);
  using Rule = Covariance::LagRule;
  CHECK(Covariance::correlation_lag(v, starts, 5, Rule::fixed) == 5);
  CHECK(Covariance::correlation_lag(Eigen::VectorXd::Zero(30), starts, 5, Rule::automatic) == 0);
  // A slowly varying residual is correlated over many lags, up to the cap.
  Eigen::VectorXd slow(30);
  for (int i = 0; i < 30; ++i) slow(i) = 1.0 + 0.01 * i;
  CHECK(Covariance::correlation_lag(slow, starts, 4, Rule::automatic) == 4);
}
