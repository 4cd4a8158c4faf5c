// MINRES and the saddle-point building blocks (pmg/sparse/saddle_point.hpp) on small random
// systems [A Bᵀ; B -C]: exact block-diagonal preconditioning ends in three iterations (C = 0), any
// initial guess reaches the tolerance on the true residual, the Chebyshev mass inverse contracts
// as its bound says, and a preconditioner that is not positive definite is a named breakdown.
#include "pmg/sparse/saddle_point.hpp"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace pmg;

namespace {

/// A dense matrix as an operator (the exact preconditioner blocks of the tests).
class Dense final : public LinearOperator {
 public:
  explicit Dense(Eigen::MatrixXd M) : M_(std::move(M)) {}
  index_t rows() const override { return static_cast<index_t>(M_.rows()); }
  index_t cols() const override { return static_cast<index_t>(M_.cols()); }

 protected:
  void apply_impl(const Vector& x, Vector& y) const override { y = M_ * x; }

 private:
  Eigen::MatrixXd M_;
};

Csr to_csr(const Eigen::MatrixXd& M) {
  std::vector<Triplet> t;
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index j = 0; j < M.cols(); ++j)
      if (M(i, j) != 0.0) t.emplace_back(static_cast<index_t>(i), static_cast<index_t>(j), M(i, j));
  return Csr::from_triplets(static_cast<index_t>(M.rows()), static_cast<index_t>(M.cols()), t);
}

/// A random saddle point: A SPD (n_u), B (n_p x n_u) of full row rank, C SPD times c (0: none).
struct Saddle {
  Eigen::MatrixXd A, B, C;
  Csr a, b, bt, c;
  std::unique_ptr<CsrCoupling> coupling;
  std::unique_ptr<SaddlePointOperator> K;
  Saddle(int nu, int np, double c_scale, unsigned seed) {
    std::mt19937 gen(seed);
    std::normal_distribution<double> normal;
    Eigen::MatrixXd G(nu, nu), H(np, nu), E(np, np);
    for (auto* M : {&G, &H, &E})
      for (Eigen::Index i = 0; i < M->size(); ++i) M->data()[i] = normal(gen);
    A = G * G.transpose() + nu * Eigen::MatrixXd::Identity(nu, nu);
    B = H;
    C = c_scale * (E * E.transpose() + Eigen::MatrixXd::Identity(np, np));
    a = to_csr(A), b = to_csr(B), bt = to_csr(B.transpose()), c = to_csr(C);
    coupling = std::make_unique<CsrCoupling>(b, bt);
    K = std::make_unique<SaddlePointOperator>(a, *coupling, c_scale > 0 ? &c : nullptr);
  }
  Eigen::MatrixXd dense() const {
    Eigen::MatrixXd k(A.rows() + B.rows(), A.rows() + B.rows());
    k << A, B.transpose(), B, -C;
    return k;
  }
};

}  // namespace

TEST_CASE("saddle point: the operator applies [A Bᵀ; B -C]", "[saddle]") {
  const Saddle s(12, 5, 0.1, 3);
  const Vector x = Vector::Random(17);
  Vector y;
  s.K->apply(x, y);
  CHECK((y - s.dense() * x).norm() <= 1e-13 * y.norm());
}

TEST_CASE("MINRES with the exact block-diagonal preconditioner ends in three iterations (C = 0)", "[saddle]") {
  // Murphy, Golub and Wathen (2000): P⁻¹K has the three eigenvalues 1 and (1 ± √5)/2.
  const Saddle s(30, 10, 0.0, 5);
  const Eigen::MatrixXd Ainv = s.A.inverse();
  const Dense Mu(Ainv), Mp((s.B * Ainv * s.B.transpose()).inverse());
  const BlockDiagonalOperator P(Mu, Mp);
  const Vector b = Vector::Random(40);
  Vector x;
  KrylovParams k;
  k.rel_tol = 1e-10;
  const SolveResult r = minres(*s.K, &P, b, x, k);
  CHECK(r.ok());
  CHECK(r.iterations <= 3);
  CHECK((b - s.dense() * x).norm() <= 2e-10 * b.norm());
}

TEST_CASE("MINRES reaches the tolerance on the true residual from any guess, with and without M", "[saddle]") {
  const Saddle s(25, 8, 0.01, 7);
  const Eigen::MatrixXd k = s.dense();
  const Dense Mu(s.A.diagonal().cwiseInverse().asDiagonal().toDenseMatrix()),
      Mp(Eigen::MatrixXd::Identity(8, 8) * (1.0 / 25));
  const BlockDiagonalOperator P(Mu, Mp);
  for (double tol : {1e-4, 1e-8, 1e-11})
    for (int guess = 0; guess < 3; ++guess)
      // (A guess 1e3 times the answer leaves rounding of eps ||K|| ||x_k|| in the updated residual,
      // about 1e-11 here: the far guess is asked for tolerances down to 1e-8.)
      if (guess < 2 || tol >= 1e-8)
      for (const LinearOperator* M : {static_cast<const LinearOperator*>(nullptr), static_cast<const LinearOperator*>(&P)}) {
        const Vector b = Vector::Random(33);
        Vector x = guess == 0 ? Vector() : guess == 1 ? Vector(Vector::Random(33)) : Vector(1e3 * Vector::Random(33));
        KrylovParams p;
        p.rel_tol = tol;
        const SolveResult r = minres(*s.K, M, b, x, p);
        INFO("tol " << tol << ", guess " << guess << (M ? ", preconditioned" : ""));
        CHECK(r.ok());
        CHECK((b - k * x).norm() <= 2 * tol * b.norm());
      }
}

TEST_CASE("MINRES: a preconditioner that is not positive definite is a named breakdown", "[saddle]") {
  const Saddle s(10, 4, 0.0, 11);
  const Dense bad(-Eigen::MatrixXd::Identity(14, 14));
  const Vector b = Vector::Random(14);
  Vector x;
  CHECK_THROWS_WITH(minres(*s.K, &bad, b, x), Catch::Contains("not symmetric positive definite"));
  CHECK_THROWS_WITH(minres(*s.K, nullptr, Vector::Random(3), x), Catch::Contains("right-hand side has 3 entries"));
}

TEST_CASE("Chebyshev mass inverse: Saad's recurrence on M in float, the same on 1 and 3 threads", "[saddle]") {
  const int n = 5000, steps = 6;
  Eigen::SparseMatrix<double, Eigen::RowMajor> M(n, n);
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0 + 0.3 * std::sin(0.1 * i));
    if (i + 1 < n) t.emplace_back(i, i + 1, 0.7), t.emplace_back(i + 1, i, 0.7);
    if (i + 50 < n) t.emplace_back(i, i + 50, 0.1), t.emplace_back(i + 50, i, 0.1);
  }
  M.setFromTriplets(t.begin(), t.end());
  const Csr m = Csr::from_eigen(M);
  const double lo = 0.2, hi = 1.8, scale = 3.0;
  const ChebyshevMassInverse inv(m, lo, hi, steps, scale);
  const Vector r = Vector::Random(n);
  // Saad, Algorithm 12.1 on D⁻¹M, written out on M's values rounded to float.
  Eigen::SparseMatrix<double, Eigen::RowMajor> Mf = M;
  for (int k = 0; k < Mf.nonZeros(); ++k) Mf.valuePtr()[k] = static_cast<float>(Mf.valuePtr()[k]);
  const Vector dinv = M.diagonal().cwiseInverse();
  const double theta = 0.5 * (hi + lo), delta = 0.5 * (hi - lo), sigma = theta / delta;
  double rho = 1.0 / sigma;
  Vector res = r, d = dinv.cwiseProduct(res) / theta, z_ref = Vector::Zero(n);
  for (int k = 1; k <= steps; ++k) {
    z_ref += d;
    if (k == steps) break;
    res -= Mf * d;
    const double rho_new = 1.0 / (2.0 * sigma - rho);
    d = (rho_new * rho) * d + (2.0 * rho_new / delta) * dinv.cwiseProduct(res);
    rho = rho_new;
  }
  z_ref *= scale;
  Vector z;
  inv.apply(r, z);
  CHECK((z - z_ref).norm() <= 1e-13 * z_ref.norm());
#ifdef _OPENMP
  // Each row's arithmetic is the same on any number of threads: bitwise equal results.
  const int before = omp_get_max_threads();
  Vector z1, z3;
  omp_set_num_threads(1);
  inv.apply(r, z1);
  omp_set_num_threads(3);
  inv.apply(r, z3);
  omp_set_num_threads(before);
  CHECK(z1 == z3);
#endif
}

TEST_CASE("Chebyshev mass inverse: the M-norm error contracts by the Chebyshev bound", "[saddle]") {
  // A mass-like SPD matrix with D⁻¹M's spectrum inside [lo, hi]; 5000 rows take the threaded pass.
  for (int n : {20, 5000}) {
    Eigen::SparseMatrix<double, Eigen::RowMajor> M(n, n);
    std::vector<Eigen::Triplet<double>> t;
    for (int i = 0; i < n; ++i) {
      t.emplace_back(i, i, 2.0 + 0.5 * (i % 3));
      if (i + 1 < n) t.emplace_back(i, i + 1, 0.9), t.emplace_back(i + 1, i, 0.9);
    }
    M.setFromTriplets(t.begin(), t.end());
    const Csr m = Csr::from_eigen(M);
    // Gershgorin's discs of D^-1/2 M D^-1/2 (diagonal 1) contain the spectrum of D⁻¹M.
    const Eigen::VectorXd d = M.diagonal();
    double radius = 0.0;
    for (int i = 0; i < n; ++i) {
      double off = 0.0;
      if (i > 0) off += 0.9 / std::sqrt(d[i] * d[i - 1]);
      if (i + 1 < n) off += 0.9 / std::sqrt(d[i] * d[i + 1]);
      radius = std::max(radius, off);
    }
    const double lo = 1.0 - radius, hi = 1.0 + radius;
    const Vector x_star = Vector::Random(n), r = M * x_star;
    for (int steps : {1, 4, 8}) {
      const ChebyshevMassInverse inv(m, lo, hi, steps, 2.0);
      Vector z;
      inv.apply(r, z);
      const double kappa = hi / lo, rho = (std::sqrt(kappa) - 1) / (std::sqrt(kappa) + 1);
      const double bound = 2 * std::pow(rho, steps) / (1 + std::pow(rho, 2 * steps));
      const Vector e = 0.5 * z - x_star;  // scale 2: z ≈ 2 M⁻¹ r
      INFO(n << " rows, " << steps << " steps");
      // M's values in float perturb the operator by about 6e-8 relative: 1e-6 covers it.
      CHECK(std::sqrt(e.dot(M * e)) <= (bound + 1e-6) * std::sqrt(x_star.dot(M * x_star)));
    }
  }
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(4, 4) * 2.0;
  const Csr m = to_csr(M);
  CHECK_THROWS_WITH(ChebyshevMassInverse(m, 1.0, 0.5, 4), Catch::Contains("0 < lo < hi"));
}

TEST_CASE("the block-triangular product equals P then K, and GMRES with it equals GMRES with P", "[saddle]") {
  // BlockTriangularOperator::apply_and_multiply reuses P's Bᵀ z_p in K z: z and w as P then K
  // give them, with and without C; the coupling's B alone and Bᵀ alone sum to both at once.
  for (double c : {0.0, 0.3}) {
    const Saddle s(20, 7, c, 11);
    const Dense Mu(s.A.diagonal().cwiseInverse().asDiagonal().toDenseMatrix()),
        Mp(Eigen::MatrixXd::Identity(7, 7) * 0.2);
    const BlockTriangularOperator P(Mu, Mp, *s.coupling);
    const BlockTriangularProduct KP(P, *s.K);
    const Vector v = Vector::Random(27);
    Vector z, w, z_ref, w_ref;
    KP.apply(v, z, w);
    P.apply(v, z_ref);
    s.K->apply(z_ref, w_ref);
    INFO("C scale " << c);
    CHECK((z - z_ref).norm() <= 1e-14 * z_ref.norm());
    CHECK((w - w_ref).norm() <= 1e-13 * w_ref.norm());
    const Vector b = Vector::Random(27);
    Vector x1, x2;
    KrylovParams k;
    k.rel_tol = 1e-10;
    const SolveResult r1 = gmres(*s.K, KP, b, x1, k), r2 = gmres(*s.K, &P, b, x2, k);
    CHECK(r1.ok());
    CHECK(r1.iterations == r2.iterations);
    CHECK((b - s.dense() * x1).norm() <= 2e-10 * b.norm());
    // B alone (x_p null) plus Bᵀ alone (x_u null) is the product of both.
    const Vector xu = Vector::Random(20), xp = Vector::Random(7);
    Vector yu = Vector::Zero(20), yp(7), yu2 = Vector::Zero(20), yp2(7);
    s.coupling->apply(xu.data(), xp.data(), yu.data(), yp.data());
    s.coupling->apply(xu.data(), nullptr, nullptr, yp2.data());
    s.coupling->apply(nullptr, xp.data(), yu2.data(), nullptr);
    CHECK((yp - yp2).norm() <= 1e-14 * yp.norm());
    CHECK((yu - yu2).norm() <= 1e-14 * yu.norm());
  }
  // A product whose saddle point is not the preconditioner's is refused by name.
  const Saddle s(20, 7, 0.0, 11), other(21, 6, 0.0, 12);
  const Dense Mu(Eigen::MatrixXd::Identity(20, 20)), Mp(Eigen::MatrixXd::Identity(7, 7));
  const BlockTriangularOperator P(Mu, Mp, *s.coupling);
  Vector z, w;
  CHECK_THROWS_WITH(P.apply_and_multiply(*other.K, Vector::Random(27), z, w), Catch::Contains("coupling or size"));
}

TEST_CASE("the block-triangular product in float: z exact in float, w = K z, and GMRES keeps z_i in float across "
          "restarts", "[saddle]") {
  for (double c : {0.0, 0.3}) {
    const Saddle s(20, 7, c, 13);
    const Dense Mu(s.A.diagonal().cwiseInverse().asDiagonal().toDenseMatrix()),
        Mp(Eigen::MatrixXd::Identity(7, 7) * 0.2);
    const BlockTriangularOperator P(Mu, Mp, *s.coupling);
    const BlockTriangularProduct KP(P, *s.K, true);
    CHECK(KP.single_precision());
    CHECK_FALSE(BlockTriangularProduct(P, *s.K).single_precision());
    const Vector v = Vector::Random(27);
    Vector z, w, w_ref, z_ref;
    KP.apply(v, z, w);
    CHECK(z == z.cast<float>().cast<double>());  // exact in float
    s.K->apply(z, w_ref);
    CHECK((w - w_ref).norm() <= 1e-13 * w_ref.norm());  // K applied to the rounded z
    P.apply(v, z_ref);
    CHECK((z - z_ref).norm() <= 1e-6 * z_ref.norm());  // P perturbed by float rounding only
    // Restarts every 3 iterations, the workspace reused by a second solve: the true residual
    // reaches 1e-10, as with the double z_i.
    const Vector b = Vector::Random(27);
    KrylovParams k;
    k.rel_tol = 1e-10;
    GmresParams g;
    g.restart = 3;
    GmresWorkspace work;
    for (int solve = 0; solve < 2; ++solve) {
      Vector x;
      const SolveResult r = gmres(*s.K, KP, b, x, k, g, nullptr, &work);
      INFO("C scale " << c << ", solve " << solve << ": " << r.iterations << " iterations");
      CHECK(r.ok());
      CHECK(r.iterations > 3);
      CHECK((b - s.dense() * x).norm() <= 2e-10 * b.norm());
      CHECK(work.Z.empty());
      CHECK(work.Zf.size() == 3);
    }
  }
}

TEST_CASE("GMRES with the exact block-triangular preconditioner ends in two iterations", "[saddle]") {
  // Murphy, Golub and Wathen (2000): K P has the single eigenvalue 1 and a minimal polynomial of
  // degree 2, with and without C.
  for (double c : {0.0, 0.3}) {
    const Saddle s(30, 10, c, 5);
    const Eigen::MatrixXd Ainv = s.A.inverse();
    const Dense Mu(Ainv), Mp((s.C + s.B * Ainv * s.B.transpose()).inverse());
    const BlockTriangularOperator P(Mu, Mp, *s.coupling);
    const Vector b = Vector::Random(40);
    Vector x;
    KrylovParams k;
    k.rel_tol = 1e-10;
    const SolveResult r = gmres(*s.K, &P, b, x, k);
    INFO("C scale " << c);
    CHECK(r.ok());
    CHECK(r.iterations <= 2);
    CHECK((b - s.dense() * x).norm() <= 2e-10 * b.norm());
  }
}

TEST_CASE("GMRES reaches the tolerance on the true residual from any guess, restarted or not, with and without M, "
          "with one or two Gram-Schmidt passes",
          "[saddle]") {
  const Saddle s(25, 8, 0.01, 7);
  const Eigen::MatrixXd k = s.dense();
  const Dense Mu(s.A.diagonal().cwiseInverse().asDiagonal().toDenseMatrix()),
      Mp(Eigen::MatrixXd::Identity(8, 8) * (1.0 / 25));
  const BlockTriangularOperator P(Mu, Mp, *s.coupling);
  std::mt19937 gen(13);
  std::normal_distribution<double> normal;
  auto random = [&] {
    Vector v(33);
    for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = normal(gen);
    return v;
  };
  for (double tol : {1e-4, 1e-8, 1e-11})
    for (int restart : {3, 10, 50})
      for (int guess = 0; guess < 2; ++guess)
        for (const LinearOperator* M : {static_cast<const LinearOperator*>(nullptr), static_cast<const LinearOperator*>(&P)}) {
          // Restarted GMRES may stagnate on an indefinite system (a restart throws away the space
          // that held the negative eigenvalues): without a preconditioner only the full space
          // (restart >= 33) is asked for. With the block-triangular preconditioner the spectrum of
          // K P lies near those of A Ã⁻¹ and S S̃⁻¹ (exactly, when Ã = A), positive for these crude
          // blocks (Jacobi, a scaled identity), and every restart is asked to converge.
          if (!M && restart < 33) continue;
          const Vector b = random();
          Vector x = guess == 0 ? Vector() : random();
          KrylovParams p;
          p.rel_tol = tol;
          p.max_iterations = 5000;
          for (bool twice : {false, true})  // one Gram–Schmidt pass, or repeated where needed
            for (bool float_basis : {false, true}) {
              GmresParams g;
              g.restart = restart;
              g.reorthogonalise = twice;
              g.float_basis = float_basis;
              Vector xg = x;
              const SolveResult r = gmres(*s.K, M, b, xg, p, g);
              INFO("tol " << tol << ", restart " << restart << ", guess " << guess << (M ? ", preconditioned" : "")
                          << (twice ? ", reorthogonalised" : "") << (float_basis ? ", float basis" : ""));
              CHECK(r.ok());
              CHECK((b - k * xg).norm() <= 2 * tol * b.norm());
              // Without restarts GMRES ends within the dimension (33), in exact arithmetic.
              if (restart == 50 && tol >= 1e-8) CHECK(r.iterations <= 33);
            }
        }
}

TEST_CASE("GMRES: the same bits on 1 and 3 threads on a system of many Gram-Schmidt blocks", "[saddle]") {
  // A sparse saddle point of 12,000 unknowns: the orthogonalisation's passes run over several
  // blocks of entries, whose sums are added in a fixed order.
  const index_t nu = 9000, np = 3000;
  std::vector<Triplet> ta, tb, tbt, tc, tmu, tmp;
  for (index_t i = 0; i < nu; ++i) {
    ta.emplace_back(i, i, 4.0 + 0.001 * (i % 7));
    if (i + 1 < nu) ta.emplace_back(i, i + 1, -1.0), ta.emplace_back(i + 1, i, -1.0);
    tmu.emplace_back(i, i, 1.0 / (4.0 + 0.001 * (i % 7)));
  }
  for (index_t i = 0; i < np; ++i) {
    const double v[3] = {1.0, -0.5, 0.25 + 0.01 * (i % 5)};
    for (int c = 0; c < 3; ++c) tb.emplace_back(i, 3 * i + c, v[c]), tbt.emplace_back(3 * i + c, i, v[c]);
    tc.emplace_back(i, i, 0.01);
    tmp.emplace_back(i, i, 2.0);
  }
  const Csr A = Csr::from_triplets(nu, nu, ta), B = Csr::from_triplets(np, nu, tb), Bt = Csr::from_triplets(nu, np, tbt),
            C = Csr::from_triplets(np, np, tc), Mu = Csr::from_triplets(nu, nu, tmu), Mp = Csr::from_triplets(np, np, tmp);
  const CsrCoupling coupling(B, Bt);
  const SaddlePointOperator K(A, coupling, &C);
  const BlockTriangularOperator P(Mu, Mp, coupling);
  Vector b(nu + np);
  for (Eigen::Index i = 0; i < b.size(); ++i) b[i] = std::sin(0.01 * static_cast<double>(i)) + 0.1;
  KrylovParams p;
  p.rel_tol = 1e-10;
  p.max_iterations = 500;
  Vector x_default = Vector::Zero(nu + np);
  const SolveResult r = gmres(K, &P, b, x_default, p);
  REQUIRE(r.ok());
  Vector res;
  K.residual(b, x_default, res);
  CHECK(res.norm() <= 1e-10 * b.norm());
  // The float basis (the default, from a residual of 1.7e-5 ||b|| on) ends where the double one does.
  GmresParams in_double;
  in_double.float_basis = false;
  Vector xd = Vector::Zero(nu + np);
  const SolveResult rd = gmres(K, &P, b, xd, p, in_double);
  REQUIRE(rd.ok());
  CHECK(r.iterations == rd.iterations);
  CHECK((x_default - xd).norm() <= 1e-9 * xd.norm());
#ifdef _OPENMP
  const int before = omp_get_max_threads();
  Vector x1 = Vector::Zero(nu + np), x3 = Vector::Zero(nu + np);
  omp_set_num_threads(1);
  const SolveResult r1 = gmres(K, &P, b, x1, p);
  omp_set_num_threads(3);
  const SolveResult r3 = gmres(K, &P, b, x3, p);
  omp_set_num_threads(before);
  CHECK(r1.iterations == r.iterations);
  CHECK(r3.iterations == r.iterations);
  CHECK(x1 == x_default);
  CHECK(x3 == x_default);
#endif
}

TEST_CASE("GMRES: a nonsymmetric system, the iteration limit and bad input are named", "[saddle]") {
  // A nonsymmetric, nonnormal matrix: MINRES does not apply, GMRES does.
  Eigen::MatrixXd A = Eigen::MatrixXd::Identity(20, 20) * 4.0;
  for (int i = 0; i + 1 < 20; ++i) A(i, i + 1) = 2.0;
  const Dense K(A);
  const Vector b = Vector::Ones(20);
  Vector x;
  KrylovParams p;
  p.rel_tol = 1e-12;
  CHECK(gmres(K, nullptr, b, x, p).ok());
  CHECK((b - A * x).norm() <= 2e-12 * b.norm());
  p.max_iterations = 3;
  p.throw_on_failure = false;
  x.setZero();
  GmresParams two;
  two.restart = 2;
  const SolveResult r = gmres(K, nullptr, b, x, p, two);
  CHECK(r.status == SolveStatus::iteration_limit);
  CHECK(r.iterations == 3);
  GmresParams none;
  none.restart = 0;
  CHECK_THROWS_WITH(gmres(K, nullptr, b, x, KrylovParams{}, none), Catch::Contains("restart must be >= 1"));
  CHECK_THROWS_WITH(gmres(K, nullptr, Vector::Random(3), x), Catch::Contains("GMRES: right-hand side has 3 entries"));
}

TEST_CASE("GMRES: a float basis that misses its estimate gives way to double, and the answer meets the tolerance",
          "[saddle]") {
  // An ill-conditioned SPD matrix (eigenvalues from 1 to 1e6, a random basis) to 1e-11 in one cycle:
  // the later coefficients of GMRES's solution are large, so float vectors move the true residual
  // past the estimate (without the fallback to double the solve ends as stagnation at 2.3e-11).
  const int n = 80;
  std::mt19937 gen(5);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd G(n, n);
  for (Eigen::Index i = 0; i < G.size(); ++i) G.data()[i] = normal(gen);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(G);
  const Eigen::MatrixXd Q = qr.householderQ();
  Eigen::VectorXd lambda(n);
  for (int i = 0; i < n; ++i) lambda[i] = std::pow(10.0, 6.0 * i / (n - 1));
  const Eigen::MatrixXd A = Q * lambda.asDiagonal() * Q.transpose();
  const Dense K(A);
  Vector b(n);
  for (int i = 0; i < n; ++i) b[i] = normal(gen);
  KrylovParams p;
  p.rel_tol = 1e-11;
  p.max_iterations = 2000;
  GmresParams g;
  g.restart = n;
  Vector x = Vector::Zero(n);
  const SolveResult r = gmres(K, nullptr, b, x, p, g);
  CHECK(r.ok());
  CHECK((b - A * x).norm() <= 2 * p.rel_tol * b.norm());
}
