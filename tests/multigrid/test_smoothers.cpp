#include "pmg/multigrid/chebyshev.hpp"
#include "pmg/sparse/generators.hpp"

#include <catch2/catch.hpp>

using namespace pmg;
using namespace pmg::mg;

namespace {
/// Plain serial Gauss–Seidel over block rows in the given order (the reference): each block row
/// solved exactly (block), or its three scalar rows relaxed one by one, 0,1,2 forward and 2,1,0
/// backward (pointwise; in natural order that is scalar Gauss–Seidel on the scalar matrix).
void reference_sweep(const Eigen::MatrixXd& A, const Vector& b, Vector& x,
                     const std::vector<index_t>& order, bool pointwise, bool forward) {
  for (index_t I : order) {
    if (pointwise) {
      for (int s = 0; s < 3; ++s) {
        const Eigen::Index i = 3 * I + (forward ? s : 2 - s);
        x[i] = (b[i] - A.row(i).dot(x) + A(i, i) * x[i]) / A(i, i);
      }
      continue;
    }
    Eigen::Vector3d r = b.segment<3>(3 * I);
    for (Eigen::Index J = 0; J < A.cols() / 3; ++J)
      if (J != I) r -= A.block<3, 3>(3 * I, 3 * J) * x.segment<3>(3 * J);
    x.segment<3>(3 * I) = A.block<3, 3>(3 * I, 3 * I).llt().solve(r);
  }
}
}  // namespace

TEST_CASE("Gauss-Seidel sweeps (block and point) match the serial reference in both orderings",
          "[multigrid][smoother]") {
  const Bcsr A = spring_lattice(5);
  const Eigen::MatrixXd D = A.to_csr().to_eigen();
  const Vector b = Vector::LinSpaced(A.rows(), -1.0, 2.0);
  for (bool pointwise : {false, true})
    for (Ordering ord : {Ordering::natural, Ordering::multicolor}) {
      GaussSeidelParams p;
      p.ordering = ord;
      p.pointwise = pointwise;
      const BlockGaussSeidel gs(A, p);
      std::vector<index_t> order;
      for (const auto& c : gs.colors()) order.insert(order.end(), c.begin(), c.end());
      std::vector<index_t> reverse(order.rbegin(), order.rend());
      Vector x = Vector::Zero(A.rows()), xr = x;
      gs.sweep(b, x, true);
      reference_sweep(D, b, xr, order, pointwise, true);
      CHECK((x - xr).norm() <= 1e-13 * xr.norm());
      gs.sweep(b, x, false);
      reference_sweep(D, b, xr, reverse, pointwise, false);
      CHECK((x - xr).norm() <= 1e-13 * xr.norm());
      if (ord == Ordering::multicolor) {
        CHECK(gs.colors().size() > 1);
        CHECK(gs.colors().size() <= 27);
      }
    }
  // The two variants are different smoothers (the diagonal blocks are not diagonal).
  GaussSeidelParams pb, pp;
  pp.pointwise = true;
  Vector xb = Vector::Zero(A.rows()), xp = xb;
  BlockGaussSeidel(A, pb).sweep(b, xb, true);
  BlockGaussSeidel(A, pp).sweep(b, xp, true);
  CHECK((xb - xp).norm() > 1e-6 * xb.norm());
}

TEST_CASE("smoothers reduce the error of an SPD system", "[multigrid][smoother]") {
  const Bcsr A = spring_lattice(6);
  const Vector x_true = smooth_field(6);
  Vector b;
  A.apply(x_true, b);
  const BlockGaussSeidel gs(A);
  const BlockJacobi jac(A);
  const Chebyshev cheb(A);
  CHECK(cheb.lambda_max() > 1.0);  // D⁻¹A has eigenvalues above 1 (its diagonal blocks are I)
  for (const Smoother* s : {static_cast<const Smoother*>(&gs), static_cast<const Smoother*>(&jac),
                            static_cast<const Smoother*>(&cheb)}) {
    Vector x = Vector::Zero(A.rows());
    s->pre_smooth(b, x);
    const double e1 = (x - x_true).norm();
    s->post_smooth(b, x);
    CHECK((x - x_true).norm() < e1);
    CHECK(e1 < x_true.norm());
  }
}

TEST_CASE("Chebyshev of each kind matches its dense serial reference, also started from zero",
          "[multigrid][smoother][chebyshev]") {
  // Reference: dense B = D⁻¹A (D the 3x3 diagonal blocks) and the published recurrences with a
  // fresh residual b - A x at every step: first kind (Saad, Alg. 12.1) on [f ρ, ρ]; fourth kind
  // (Phillips & Fischer 2022) on [0, ρ]; its optimised variant (Lottes 2023) weights the same
  // fourth-kind updates d_k by beta_k.
  const Bcsr A = spring_lattice(4);
  const Eigen::MatrixXd Ad = A.to_csr().to_eigen();
  const Eigen::Index n = Ad.rows();
  Eigen::MatrixXd Dinv = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index I = 0; I < n / 3; ++I) Dinv.block<3, 3>(3 * I, 3 * I) = Ad.block<3, 3>(3 * I, 3 * I).inverse();
  const Vector b = Vector::LinSpaced(n, -1.0, 2.0);
  const Vector x0 = 0.1 * Vector::LinSpaced(n, 1.0, -0.5);
  const double betas3[3] = {1.00842544782028, 1.08867839208730, 1.33753125909618};
  for (ChebyshevKind kind : {ChebyshevKind::first, ChebyshevKind::fourth, ChebyshevKind::optimal_fourth}) {
    for (int m : {1, 3}) {
      INFO("kind " << static_cast<int>(kind) << ", degree " << m);
      ChebyshevParams p;
      p.kind = kind;
      p.degree = m;
      const Chebyshev cheb(A, p);
      const double rho = cheb.lambda_max();
      Vector x_ref = x0;
      if (kind == ChebyshevKind::first) {
        const double lmin = p.lower_fraction * rho, theta = 0.5 * (rho + lmin), delta = 0.5 * (rho - lmin);
        const double sigma = theta / delta;
        double r_old = 1.0 / sigma;
        Vector d = Dinv * (b - Ad * x_ref) / theta;
        for (int k = 1; k <= m; ++k) {
          x_ref += d;
          const double r_new = 1.0 / (2.0 * sigma - r_old);
          d = r_new * r_old * d + (2.0 * r_new / delta) * (Dinv * (b - Ad * x_ref));
          r_old = r_new;
        }
      } else {
        Vector y = x0;  // the unweighted fourth-kind iterate
        Vector d = (4.0 / 3.0 / rho) * (Dinv * (b - Ad * y));
        for (int k = 1; k <= m; ++k) {
          const double beta = kind == ChebyshevKind::optimal_fourth ? (m == 1 ? 1.125 : betas3[k - 1]) : 1.0;
          x_ref += beta * d;
          y += d;
          d = (2.0 * k - 1) / (2.0 * k + 3) * d + (8.0 * k + 4) / (2.0 * k + 3) / rho * (Dinv * (b - Ad * y));
        }
      }
      Vector x = x0;
      cheb.pre_smooth(b, x);
      CHECK((x - x_ref).norm() <= 1e-12 * x_ref.norm());
      // From zero: the same as smoothing a zero vector, with one product fewer.
      Vector z1 = Vector::Zero(n), z2;
      cheb.pre_smooth(b, z1);
      cheb.pre_smooth_from_zero(b, z2);
      CHECK((z1 - z2).norm() <= 1e-13 * z1.norm());
      CHECK(z1.norm() > 0);
    }
  }
  ChebyshevParams bad;
  bad.kind = ChebyshevKind::optimal_fourth;
  bad.degree = 7;
  CHECK_THROWS_AS(Chebyshev(bad), InputError);
}

TEST_CASE("a smoother refuses a matrix whose diagonal blocks are not SPD", "[multigrid][smoother][errors]") {
  Bcsr A = spring_lattice(3);
  A.block(A.find_block(4, 4)) = -Block3::Identity();
  CHECK_THROWS_WITH(BlockGaussSeidel(A), Catch::Contains("diagonal block 4"));
}

TEST_CASE("l1 block Jacobi matches its dense serial reference and converges undamped", "[multigrid][smoother]") {
  // Reference: M = blockdiag(A_II) + diag(Σ_{J≠I} Σ_c |A_IJ(r, c)|) built densely, one sweep
  // x += M⁻¹ (b - A x).
  const Bcsr A = spring_lattice(5);
  const Eigen::MatrixXd D = A.to_csr().to_eigen();
  const Eigen::Index n = D.rows();
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index I = 0; I < n / 3; ++I) {
    M.block<3, 3>(3 * I, 3 * I) = D.block<3, 3>(3 * I, 3 * I);
    for (int r = 0; r < 3; ++r)
      for (Eigen::Index j = 0; j < n; ++j)
        if (j / 3 != I) M(3 * I + r, 3 * I + r) += std::abs(D(3 * I + r, j));
  }
  const Vector b = Vector::LinSpaced(n, -1.0, 2.0);
  JacobiParams p;
  p.sweeps = 1;
  p.omega = 1.0;
  p.l1 = true;
  const BlockJacobi l1(A, p);
  Vector x = Vector::Zero(n), x_ref = Vector::Zero(n);
  for (int sweep = 0; sweep < 3; ++sweep) {
    l1.pre_smooth(b, x);
    x_ref += M.ldlt().solve(b - D * x_ref);
  }
  CHECK((x - x_ref).norm() <= 1e-12 * x_ref.norm());
  // Undamped, it still reduces the energy norm of the error of an SPD system at every sweep (the
  // l1 smoother's guarantee; plain block Jacobi with ω = 1 has none).
  const Vector x_true = smooth_field(5);
  Vector rhs;
  A.apply(x_true, rhs);
  auto energy = [&](const Vector& e) { return std::sqrt(e.dot(D * e)); };
  Vector y = Vector::Zero(n);
  double e = energy(x_true);
  for (int sweep = 0; sweep < 10; ++sweep) {
    l1.pre_smooth(rhs, y);
    const double e_new = energy(y - x_true);
    CHECK(e_new < e);
    e = e_new;
  }
  // Only BCSR carries the blocks it sums.
  BlockJacobi on_csr(p);
  const Csr S = A.to_csr();
  CHECK_THROWS_WITH(on_csr.setup(S), Catch::Contains("l1-jacobi: needs the matrix as BCSR"));
}

TEST_CASE("the Lanczos estimate of lambda_max lies within the 10% margin where power steps fall short",
          "[multigrid][smoother]") {
  // The exact λmax of D⁻¹A from the dense generalized eigenproblem A v = λ D v.
  const Bcsr A = spring_lattice(6);
  const Eigen::MatrixXd dense = A.to_csr().to_eigen().toDense();
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(dense.rows(), dense.cols());
  for (Eigen::Index I = 0; I < dense.rows() / 3; ++I) D.block<3, 3>(3 * I, 3 * I) = dense.block<3, 3>(3 * I, 3 * I);
  const double exact = Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd>(dense, D).eigenvalues().maxCoeff();
  ChebyshevParams power, lanczos;
  lanczos.lanczos = true;
  power.power_iterations = lanczos.power_iterations = 10;
  const double by_power = Chebyshev(A, power).lambda_max() / 1.1, by_lanczos = Chebyshev(A, lanczos).lambda_max() / 1.1;
  INFO("exact " << exact << ", 10 power steps " << by_power << ", 10 Lanczos steps " << by_lanczos);
  CHECK(by_lanczos <= exact * (1 + 1e-10));  // a Ritz value: never above
  CHECK(by_lanczos >= exact / 1.1);          // inside the margin the smoother adds
  CHECK(std::abs(exact - by_lanczos) <= std::abs(exact - by_power));

  // Lanczos at set-up, then warm-started power steps per update (the matrix-free route's default):
  // the first update has no power vector yet and runs kColdPowerIterations from the fixed start,
  // as a power set-up of that many steps does; the next one goes on from its vector.
  ChebyshevParams warm = lanczos;
  warm.update_iterations = 1;
  Chebyshev both(A, warm);
  CHECK(both.lambda_max() == Approx(Chebyshev(A, lanczos).lambda_max()).epsilon(1e-12));
  ChebyshevParams cold;
  cold.power_iterations = ChebyshevParams::kColdPowerIterations;
  both.update();
  CHECK(both.lambda_max() == Approx(Chebyshev(A, cold).lambda_max()).epsilon(1e-12));
  both.update();
  cold.power_iterations += 1;
  CHECK(both.lambda_max() == Approx(Chebyshev(A, cold).lambda_max()).epsilon(1e-12));
}
