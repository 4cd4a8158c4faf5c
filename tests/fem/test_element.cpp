#include "pmg/fem/element.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pmg;
using namespace pmg::fem;

namespace {
const Vec3 X[4] = {Vec3(0.1, 0.0, 0.2), Vec3(1.3, 0.1, 0.0), Vec3(0.2, 0.9, 0.1), Vec3(0.3, 0.2, 1.1)};
double factorial(int n) { return n <= 1 ? 1.0 : n * factorial(n - 1); }
}  // namespace

TEST_CASE("Grundmann-Moller quadrature is exact for monomials of its degree", "[fem][quadrature]") {
  for (int deg : {1, 3, 5, 7}) {
    const QuadratureRule& q = tet_quadrature(deg);
    double wsum = 0.0;
    for (double w : q.weights) wsum += w;
    CHECK(wsum == Approx(1.0).epsilon(1e-13));
    // ∫ λ^γ dV / V = 6 γ!/(|γ|+3)!
    for (int a = 0; a <= deg; ++a)
      for (int b = 0; a + b <= deg; ++b)
        for (int c = 0; a + b + c <= deg; ++c) {
          const int d = deg - a - b - c;
          double s = 0.0;
          for (size_t k = 0; k < q.points.size(); ++k) {
            const auto& l = q.points[k];
            s += q.weights[k] * std::pow(l[0], a) * std::pow(l[1], b) * std::pow(l[2], c) * std::pow(l[3], d);
          }
          const double exact = 6.0 * factorial(a) * factorial(b) * factorial(c) * factorial(d) / factorial(deg + 3);
          CHECK(s == Approx(exact).epsilon(1e-12));
        }
  }
}

TEST_CASE("closed-form stiffness equals the quadrature of ∇B_a ∇B_bᵀ", "[fem][element]") {
  const ElementGeometry g = element_geometry(X[0], X[1], X[2], X[3]);
  const double lam = 2.0, mu = 0.7;
  for (int p = 1; p <= 3; ++p) {
    const ElementTables& t = element_tables(p);
    Eigen::MatrixXd K;
    element_stiffness(t, g, lam, mu, K);
    const QuadratureRule& q = tet_quadrature(2 * p - 2);
    const auto& alpha = multi_indices(p);
    Eigen::MatrixXd Kq = Eigen::MatrixXd::Zero(3 * t.n, 3 * t.n);
    for (size_t k = 0; k < q.points.size(); ++k)
      for (int a = 0; a < t.n; ++a)
        for (int b = 0; b < t.n; ++b) {
          const Vec3 ga = g.grad.transpose() * bernstein_gradient(alpha[a], q.points[k]);
          const Vec3 gb = g.grad.transpose() * bernstein_gradient(alpha[b], q.points[k]);
          const Mat3 S = ga * gb.transpose();
          Kq.block<3, 3>(3 * a, 3 * b) += q.weights[k] * g.volume *
              (lam * S + mu * S.transpose() + mu * S.trace() * Mat3::Identity());
        }
    CHECK((K - Kq).norm() <= 1e-12 * K.norm());
    CHECK((K - K.transpose()).norm() <= 1e-14 * K.norm());
    // Rigid translations and infinitesimal rotations are in the kernel.
    Eigen::VectorXd tx = Eigen::VectorXd::Zero(3 * t.n), rot = tx;
    for (int a = 0; a < t.n; ++a) {
      Vec3 Xa = Vec3::Zero();
      for (int i = 0; i < 4; ++i) Xa += alpha[a][i] / double(p) * X[i];
      tx[3 * a] = 1.0;
      rot.segment<3>(3 * a) = Vec3(0.3, -0.2, 0.5).cross(Xa);
    }
    CHECK((K * tx).norm() <= 1e-12 * K.norm());
    CHECK((K * rot).norm() <= 1e-12 * K.norm());
  }
}

TEST_CASE("mass table: Σ_ab ∫B_aB_b = V and rows sum to ∫B_a", "[fem][element]") {
  for (int p = 1; p <= 3; ++p) {
    const ElementTables& t = element_tables(p);
    CHECK(t.mass.sum() == Approx(1.0 / 6.0).epsilon(1e-14));
    for (int a = 0; a < t.n; ++a) CHECK(t.mass.row(a).sum() == Approx(t.load).epsilon(1e-13));
    CHECK(t.load * t.n == Approx(1.0 / 6.0));  // ∫ B_a = V / C(p+3,3)
  }
}

TEST_CASE("degenerate and inverted elements are rejected", "[fem][element][errors]") {
  CHECK_THROWS_AS(element_geometry(X[0], X[2], X[1], X[3]), MeshError);
  CHECK_THROWS_AS(element_geometry(X[0], X[1], X[2], Vec3(X[0] + X[1] - X[2])), MeshError);
}
