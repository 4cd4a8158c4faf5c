#include "fixture.hpp"

#include "pmg/sparse/generators.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace pmg;
using namespace pmg::test;

namespace {
struct LatticeSystem {
  Bcsr A = spring_lattice(8);
  Vector x_true = smooth_field(8);
  Vector b = A.to_csr().to_eigen() * x_true;
};

double true_rel_residual(const LinearOperator& A, const Vector& b, const Vector& x,
                         const Vector& x0) {
  Vector r, r0;
  A.residual(b, x, r);
  A.residual(b, x0, r0);
  return r.norm() / r0.norm();
}
}  // namespace

TEST_CASE("dot: within rounding of a long double sum, and the same bits on any number of threads",
          "[sparse][krylov]") {
  // Lengths around the block of 8192 entries and the eight partial sums.
  for (Eigen::Index n : {0, 1, 7, 9, 8191, 8192, 8193, 100003}) {
    Vector x(n), y(n);
    long double exact = 0.0L, magnitude = 0.0L;
    for (Eigen::Index i = 0; i < n; ++i) {
      x[i] = std::sin(0.37 * static_cast<double>(i)) * (1.0 + 1e-3 * static_cast<double>(i % 101));
      y[i] = std::cos(0.11 * static_cast<double>(i)) - 0.25;
      exact += static_cast<long double>(x[i]) * y[i];
      magnitude += std::abs(static_cast<long double>(x[i]) * y[i]);
    }
    const double d = ops::dot(x, y);
    INFO("n = " << n);
    CHECK(std::abs(static_cast<long double>(d) - exact) <= 1e-14L * magnitude);
    CHECK(ops::dot_serial(x.data(), y.data(), n) == Approx(d).epsilon(1e-13).margin(1e-300));
#ifdef _OPENMP
    const int before = omp_get_max_threads();
    omp_set_num_threads(1);
    const double d1 = ops::dot(x, y);
    omp_set_num_threads(3);
    const double d3 = ops::dot(x, y);
    omp_set_num_threads(before);
    CHECK(d1 == d);
    CHECK(d3 == d);
#endif
  }
}

TEST_CASE("block_diagonal_update_dot: r += a w, z = D r and r^T z in one pass, the same bits on any number of threads",
          "[sparse][krylov]") {
  // Lengths around its block of 8190 entries (whole 3x3 blocks).
  for (Eigen::Index nb : {0, 1, 2729, 2730, 2731, 33334}) {
    const Eigen::Index n = 3 * nb;
    Vector w(n), r0(n);
    std::vector<double> D(static_cast<size_t>(9 * nb));
    for (Eigen::Index i = 0; i < n; ++i) {
      w[i] = std::cos(0.23 * static_cast<double>(i));
      r0[i] = std::sin(0.37 * static_cast<double>(i)) + 0.1;
    }
    for (size_t k = 0; k < D.size(); ++k) D[k] = (k % 9 == 0 || k % 9 == 4 || k % 9 == 8 ? 2.0 : 0.0) + 0.1 * std::sin(0.5 * k);
    for (double a : {0.0, -0.75}) {
      INFO("blocks = " << nb << ", a = " << a);
      Vector r = r0, z;
      const double d = ops::block_diagonal_update_dot(a, w, D, r, z);
      Vector r_ref = r0, z_ref;
      ops::axpy(a, w, r_ref);
      ops::block_diagonal_apply(D, r_ref, z_ref);
      CHECK(r == r_ref);
      CHECK(z == z_ref);
      long double exact = 0.0L, magnitude = 0.0L;
      for (Eigen::Index i = 0; i < n; ++i) {
        exact += static_cast<long double>(r_ref[i]) * z_ref[i];
        magnitude += std::abs(static_cast<long double>(r_ref[i]) * z_ref[i]);
      }
      CHECK(std::abs(static_cast<long double>(d) - exact) <= 1e-14L * magnitude);
#ifdef _OPENMP
      const int before = omp_get_max_threads();
      for (int threads : {1, 3}) {
        omp_set_num_threads(threads);
        Vector rt = r0, zt;
        CHECK(ops::block_diagonal_update_dot(a, w, D, rt, zt) == d);
      }
      omp_set_num_threads(before);
#endif
    }
  }
}

TEST_CASE("CG and PCG reach the tolerance on the true residual and recover the solution",
          "[sparse][krylov]") {
  const LatticeSystem s;
  KrylovParams p;
  p.rel_tol = 1e-10;
  const JacobiPreconditioner jac(s.A);
  const BlockJacobiPreconditioner bjac(s.A);
  int its_cg = 0;
  for (const LinearOperator* M : {static_cast<const LinearOperator*>(nullptr),
                                  static_cast<const LinearOperator*>(&jac),
                                  static_cast<const LinearOperator*>(&bjac)}) {
    Vector x = Vector::Zero(s.b.size());
    SolveMonitor mon;
    const SolveResult r = pcg(s.A, M, s.b, x, p, &mon);
    CHECK(r.status == SolveStatus::converged);
    CHECK(r.true_rel_residual <= 2e-10);
    CHECK(true_rel_residual(s.A, s.b, x, Vector::Zero(s.b.size())) <= 2e-10);
    CHECK((x - s.x_true).norm() / s.x_true.norm() < 1e-7);
    REQUIRE(mon.history().size() == static_cast<size_t>(r.iterations) + 1);
    CHECK(mon.history().front().rel_residual == 1.0);
    for (size_t i = 1; i < mon.history().size(); ++i)
      CHECK(mon.history()[i].seconds >= mon.history()[i - 1].seconds);
    if (!M) its_cg = r.iterations;
    else CHECK(r.iterations < its_cg);
  }
}

TEST_CASE("merged CG agrees with block-Jacobi PCG to round-off", "[sparse][krylov][mcg]") {
  const LatticeSystem s;
  const BlockJacobiPreconditioner M(s.A);
  KrylovParams p;
  p.rel_tol = 1e-9;
  SolveMonitor m1, m2;
  Vector x1 = Vector::Zero(s.b.size()), x2 = x1;
  const SolveResult r1 = pcg(s.A, &M, s.b, x1, p, &m1);
  const SolveResult r2 = mcg(s.A, M, s.b, x2, p, &m2);
  CHECK(r1.status == SolveStatus::converged);
  CHECK(r2.status == SolveStatus::converged);
  CHECK(r1.iterations == r2.iterations);
  CHECK(rel_diff(x2, x1) < 1e-10);
  for (size_t i = 0; i < std::min(m1.history().size(), m2.history().size()); ++i)
    CHECK(m2.history()[i].rel_residual ==
          Approx(m1.history()[i].rel_residual).epsilon(1e-6).margin(1e-12));

  SECTION("on the BIN-BCSR layout too") {
    const BinBcsr bin(s.A);
    Vector x3 = Vector::Zero(s.b.size());
    const SolveResult r3 = mcg(bin, M, s.b, x3, p);
    CHECK(r3.iterations == r1.iterations);
    CHECK(rel_diff(x3, x1) < 1e-10);
  }
  SECTION("reading the residual every k iterations stops at a multiple of k") {
    p.check_every = 8;
    Vector x3 = Vector::Zero(s.b.size());
    const SolveResult r3 = mcg(s.A, M, s.b, x3, p);
    CHECK(r3.status == SolveStatus::converged);
    CHECK(r3.iterations % 8 == 0);
    CHECK(r3.iterations >= r1.iterations);
    CHECK(r3.iterations < r1.iterations + 8);
  }
}

TEST_CASE("fixed-iteration mode runs exactly the iterations asked for", "[sparse][krylov]") {
  const LatticeSystem s;
  KrylovParams p;
  p.fixed_iterations = true;
  p.max_iterations = 20;
  Vector x = Vector::Zero(s.b.size());
  SolveMonitor mon;
  const SolveResult r = cg(s.A, s.b, x, p, &mon);
  CHECK(r.status == SolveStatus::completed);
  CHECK(r.ok());
  CHECK(r.iterations == 20);
  CHECK(mon.history().size() == 21);
  CHECK(r.rel_residual < 1.0);
}

TEST_CASE("a zero right-hand side gives the zero solution at once", "[sparse][krylov]") {
  const Bcsr A = spring_lattice(3);
  Vector x;
  const SolveResult r = cg(A, Vector::Zero(A.rows()), x);
  CHECK(r.status == SolveStatus::converged);
  CHECK(r.iterations == 0);
  CHECK(x.isZero());
}

TEST_CASE("an indefinite matrix is a breakdown, not a solution", "[sparse][krylov][errors]") {
  const Csr A = Csr::from_triplets(3, 3, {{0, 0, 2.0}, {1, 1, -1.0}, {2, 2, 1.0}});
  Vector x;
  const Vector b = Vector::Ones(3);
  CHECK_THROWS_WITH(cg(A, b, x), Catch::Contains("not symmetric positive definite"));
  try {
    cg(A, b, x);
  } catch (const SolveError& e) {
    CHECK(e.result.status == SolveStatus::breakdown);
  }
  SECTION("a preconditioner that is not SPD is a breakdown too") {
    const Csr S = Csr::from_triplets(3, 3, {{0, 0, 2.0}, {1, 1, 1.0}, {2, 2, 1.0}});
    const Csr negative = Csr::from_triplets(3, 3, {{0, 0, -1.0}, {1, 1, -1.0}, {2, 2, -1.0}});
    CHECK_THROWS_WITH(pcg(S, &negative, b, x), Catch::Contains("r^T M^{-1} r"));
    CHECK_THROWS_AS(JacobiPreconditioner(negative), InputError);
  }
}

TEST_CASE("a diverging iteration is detected", "[sparse][krylov][errors]") {
  // Symmetric indefinite with p^T A p = 2e-9 + 1e-18 > 0 at the first step: alpha ~ 1e9 and the
  // residual jumps by that factor.
  const Csr A = Csr::from_triplets(2, 2, {{0, 0, 1.0}, {1, 1, -1.0}});
  Vector b(2);
  b << 1.0 + 1e-9, 1.0;
  Vector x;
  KrylovParams p;
  p.throw_on_failure = false;
  const SolveResult r = cg(A, b, x, p);
  CHECK(r.status == SolveStatus::diverged);
  CHECK_THAT(r.message, Catch::Contains("divergence limit"));
}

TEST_CASE("NaN in the matrix or the right-hand side is reported", "[sparse][krylov][errors]") {
  const Bcsr A0 = spring_lattice(3);
  Vector b = Vector::Ones(A0.rows()), x;
  Bcsr A = A0;
  A.values()[0] = std::numeric_limits<double>::quiet_NaN();  // in the first diagonal block
  try {
    cg(A, b, x);
    FAIL("no error");
  } catch (const SolveError& e) {
    CHECK(e.result.status == SolveStatus::non_finite);
  }
  b[3] = std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH(cg(A0, b, x), Catch::Contains("right-hand side has NaN/Inf"));
  CHECK_THROWS_AS(BlockJacobiPreconditioner(A), InputError);
}

TEST_CASE("an inconsistent singular system is reported, not returned as a solution", "[sparse][krylov][errors]") {
  // 1-D Neumann Laplacian (singular: constants) with a right-hand side outside its range.
  const index_t n = 30;
  std::vector<Triplet> t;
  for (index_t i = 0; i + 1 < n; ++i) {
    t.emplace_back(i, i, 1.0);
    t.emplace_back(i + 1, i + 1, 1.0);
    t.emplace_back(i, i + 1, -1.0);
    t.emplace_back(i + 1, i, -1.0);
  }
  const Csr A = Csr::from_triplets(n, n, t);
  const Vector b = Vector::Ones(n) + Vector::LinSpaced(n, 0, 1);  // not orthogonal to the null space
  Vector x;
  KrylovParams p;
  p.stagnation_window = 100;
  try {
    cg(A, b, x, p);
    FAIL("no error");
  } catch (const SolveError& e) {
    CHECK((e.result.status == SolveStatus::stagnated || e.result.status == SolveStatus::breakdown ||
           e.result.status == SolveStatus::diverged));
    CHECK(e.result.true_rel_residual > 0.5);
  }
}

TEST_CASE("an unattainable tolerance ends as stagnation at the true residual",
          "[sparse][krylov][errors]") {
  const LatticeSystem s;
  KrylovParams p;
  p.rel_tol = 1e-22;
  p.throw_on_failure = false;
  Vector x = Vector::Zero(s.b.size());
  const SolveResult r = cg(s.A, s.b, x, p);
  CHECK(r.status == SolveStatus::stagnated);
  CHECK_THAT(r.message, Catch::Contains("attainable accuracy"));
  CHECK(r.true_rel_residual < 1e-12);  // the solution itself is as good as doubles allow
}

TEST_CASE("the iteration limit is a failure in tolerance mode", "[sparse][krylov][errors]") {
  const LatticeSystem s;
  KrylovParams p;
  p.max_iterations = 5;
  Vector x = Vector::Zero(s.b.size());
  CHECK_THROWS_WITH(cg(s.A, s.b, x, p), Catch::Contains("after 5 iterations"));
}

TEST_CASE("CG used as an operator returns an early stop but refuses a breakdown", "[sparse][krylov][solver]") {
  // apply() is how a cycle uses an inner CG: stopping at its iteration limit is a usable
  // correction, a breakdown (an indefinite operator) is an error even with throw_on_failure off.
  KrylovParams p;
  p.throw_on_failure = false;
  p.max_iterations = 2;
  p.rel_tol = 1e-14;
  const Bcsr A = spring_lattice(4);
  Cg cg(p);
  cg.setup(A);
  Vector z;
  CHECK_NOTHROW(cg.apply(Vector::Ones(A.rows()), z));
  CHECK(z.allFinite());
  const Csr S = Csr::from_triplets(2, 2, {{0, 0, 1.0}, {1, 1, -1.0}});
  Cg indefinite(p);
  indefinite.setup(S);
  CHECK_THROWS_AS(indefinite.apply(Vector::Ones(2), z), SolveError);
}

TEST_CASE("merged CG testing its residual rarely converges: no false breakdown or stagnation past tol",
          "[sparse][krylov][mcg]") {
  const LatticeSystem s;
  const BlockJacobiPreconditioner M(s.A);
  KrylovParams p;
  p.rel_tol = 1e-8;
  p.check_every = 5000;  // far beyond the iterations needed: rᵀz and pᵀAp underflow to 0 first
  Vector x = Vector::Zero(s.b.size());
  const SolveResult r = mcg(s.A, M, s.b, x, p);
  CHECK(r.status == SolveStatus::converged);
  CHECK(r.message.empty());
  CHECK(true_rel_residual(s.A, s.b, x, Vector::Zero(s.b.size())) <= 2e-8);
}

TEST_CASE("a preconditioner used as a solver reports its one correction as completed, not converged",
          "[sparse][krylov]") {
  const LatticeSystem s;
  BlockJacobiPreconditioner M;
  M.setup(s.A);
  Vector x;
  const SolveResult r = M.solve(s.b, x);
  CHECK(r.status == SolveStatus::completed);
  CHECK(r.iterations == 1);
  CHECK(r.true_rel_residual == Approx(true_rel_residual(s.A, s.b, x, Vector::Zero(s.b.size()))));
  // A 0x0 system is named, not blamed on the constraints.
  const Csr empty = Csr::from_triplets(0, 0, {});
  BlockJacobiPreconditioner none;
  CHECK_THROWS_WITH(none.setup(empty), Catch::Contains("0x0: there is nothing to solve"));
}

TEST_CASE("flexible CG: a preconditioner that varies between applications still converges, and with a fixed one it is "
          "standard PCG", "[sparse][krylov][flexible]") {
  const LatticeSystem s;
  // The varying preconditioner: an inner CG to a loose tolerance (a different map for each input).
  KrylovParams inner;
  inner.rel_tol = 0.3;
  inner.max_iterations = 50;
  inner.throw_on_failure = false;
  auto M = std::make_unique<Cg>(inner);
  M->setup(s.A);
  REQUIRE_FALSE(M->is_linear());
  KrylovParams p;
  p.rel_tol = 1e-10;
  p.max_iterations = 2000;
  p.throw_on_failure = false;
  p.flexible = true;
  Vector x = Vector::Zero(s.b.size());
  const SolveResult flexible = pcg(s.A, M.get(), s.b, x, p);
  CHECK(flexible.status == SolveStatus::converged);
  CHECK(true_rel_residual(s.A, s.b, x, Vector::Zero(s.b.size())) <= 2e-10);
  CHECK((x - s.x_true).norm() <= 1e-7 * s.x_true.norm());
  // Far fewer iterations than plain CG: the inner solves do the work.
  Vector x_cg = Vector::Zero(s.b.size());
  const SolveResult plain = cg(s.A, s.b, x_cg, p);
  INFO("flexible PCG " << flexible.iterations << " iterations, CG " << plain.iterations);
  CHECK(flexible.iterations * 3 < plain.iterations);

  // A fixed preconditioner: the flexible and the standard beta agree (to round-off), iteration for
  // iteration.
  const BlockJacobiPreconditioner bjac(s.A);
  Vector x_std = Vector::Zero(s.b.size()), x_flex = Vector::Zero(s.b.size());
  p.flexible = false;
  const SolveResult standard = pcg(s.A, &bjac, s.b, x_std, p);
  p.flexible = true;
  const SolveResult flex_fixed = pcg(s.A, &bjac, s.b, x_flex, p);
  CHECK(standard.status == SolveStatus::converged);
  CHECK(flex_fixed.status == SolveStatus::converged);
  CHECK(std::abs(standard.iterations - flex_fixed.iterations) <= 1);
  CHECK((x_std - x_flex).norm() <= 1e-8 * x_std.norm());

  // As a Solver: a Cg over a nonlinear preconditioner becomes flexible by itself and says so.
  p.flexible = false;
  Cg outer(p, std::move(M));
  CHECK(outer.params().flexible);
  CHECK(outer.name().rfind("flexible cg(", 0) == 0);
}
