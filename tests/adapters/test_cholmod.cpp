#include "../sparse/fixture.hpp"

#include "pmg/cholmod/cholmod_solver.hpp"
#include "pmg/sparse/generators.hpp"

#include <catch2/catch.hpp>

#include <dlfcn.h>
#include <omp.h>

#include <thread>
#include <vector>

using namespace pmg;
using namespace pmg::test;

TEST_CASE("CHOLMOD solves the lattice to round-off and refactorises on the same pattern",
          "[sparse][cholmod]") {
  Csr A = spring_lattice(8).to_csr();
  const Vector x_true = smooth_field(8);
  const Vector b = A.to_eigen() * x_true;
  CholmodSolver chol;
  chol.analyze(A);
  chol.factorize(A);
  CHECK(chol.factor_nnz() > A.nnz() / 2);
  Vector x;
  chol.apply(b, x);
  CHECK((x - x_true).norm() / x_true.norm() < 1e-10);

  for (double& v : A.values()) v *= 2.0;  // new values, same pattern: numeric step only
  chol.factorize(A);
  chol.apply(b, x);
  CHECK((2.0 * x - x_true).norm() / x_true.norm() < 1e-10);
}

TEST_CASE("CHOLMOD with blas_threads: the same factor, the BLAS's own setting restored after each call",
          "[sparse][cholmod]") {
  // A lattice large enough for supernodes (BLAS calls) in the factor.
  Csr A = spring_lattice(14).to_csr();
  const Vector x_true = smooth_field(14);
  const Vector b = A.to_eigen() * x_true;
  using GetFn = int (*)();
  const auto get = reinterpret_cast<GetFn>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  const int before = get ? get() : 0;
  CholmodSolver plain, one("metis", 1);
  plain.compute(A);
  one.compute(A);
  Vector x0, x1;
  plain.apply(b, x0);
  one.apply(b, x1);
  CHECK((x1 - x_true).norm() / x_true.norm() < 1e-10);
  CHECK((x1 - x0).norm() / x0.norm() < 1e-12);
  if (get) CHECK(get() == before);  // OpenBLAS present (as in CI): its count is left as found
  CHECK_THAT(one.describe(), Catch::Contains("BLAS threads 1"));
  CHECK_THROWS_AS(CholmodSolver("metis", -1), InputError);
}

TEST_CASE("CHOLMOD on BCSR orders the graph of the 3x3 blocks: a factor as good, the same solution",
          "[sparse][cholmod]") {
  const Bcsr A = spring_lattice(10);
  const Csr S = A.to_csr();
  const Vector x_true = smooth_field(10);
  const Vector b = S.to_eigen() * x_true;
  CholmodSolver blocks, scalar;
  blocks.setup(A);  // BCSR: METIS on the nodes' graph
  scalar.setup(S);  // CSR: METIS on the unknowns' graph
  CHECK_THAT(blocks.describe(), Catch::Contains("ordering METIS (on the 3x3 blocks)"));
  CHECK(blocks.ordering() == "METIS");
  CHECK_THAT(scalar.describe(), !Catch::Contains("3x3 blocks"));
  // Nested dissection of the nodes is nested dissection of the unknowns with each node's three
  // kept together: about the same fill (the systems of docs/performance.md: within 2%).
  CHECK(blocks.factor_nnz() < 1.1 * scalar.factor_nnz());
  Vector xb, xs;
  blocks.apply(b, xb);
  scalar.apply(b, xs);
  CHECK((xb - x_true).norm() / x_true.norm() < 1e-10);
  CHECK((xb - xs).norm() / xs.norm() < 1e-10);
  // Another ordering asked for: CHOLMOD's own, on the unknowns.
  CholmodSolver amd("amd");
  amd.setup(A);
  CHECK_THAT(amd.describe(), Catch::Contains("ordering AMD"));
}

TEST_CASE("CHOLMOD with factor_threads: threaded factorisations, serial solves, workers ended between",
          "[sparse][cholmod]") {
  // 16^3 nodes: 2.6e9 flops, above the threshold for a threaded factorisation.
  Bcsr A = spring_lattice(16);
  const Vector x_true = smooth_field(16);
  const Vector b = A.to_csr().to_eigen() * x_true;
  using GetFn = int (*)();
  const auto get = reinterpret_cast<GetFn>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  const int before = get ? get() : 0;
  CholmodSolver chol("metis", 1, 0);
  chol.setup(A);
  CHECK_THAT(chol.describe(), Catch::Contains("factorisation BLAS threads default"));
  Vector x;
  chol.apply(b, x);
  CHECK((x - x_true).norm() / x_true.norm() < 1e-10);
  for (int k = 0; k < 2; ++k) {  // each refactorisation starts the workers anew
    for (double& v : A.values()) v *= 2.0;
    chol.update();
    chol.apply(b, x);
    CHECK((x * (k == 0 ? 2.0 : 4.0) - x_true).norm() / x_true.norm() < 1e-10);
  }
  if (get) CHECK(get() == before);
  CHECK_THROWS_AS(CholmodSolver("metis", 1, -2), InputError);
}

TEST_CASE("CHOLMOD on one BLAS thread: serial OpenMP regions give the same factor, and the setting is restored",
          "[sparse][cholmod]") {
  // 12^3 nodes: supernodes wide enough for CHOLMOD's parallel copies; below the threaded
  // factorisation's threshold, so blas_threads 1 factorises on one thread.
  Bcsr A = spring_lattice(12);
  const Vector x_true = smooth_field(12);
  const Vector b = A.to_csr().to_eigen() * x_true;
  const int levels = omp_get_max_active_levels();
  CholmodSolver serial("metis", 1), reference("metis", 0);
  serial.setup(A);
  reference.setup(A);
  CHECK(omp_get_max_active_levels() == levels);
  Vector x, x_ref;
  serial.apply(b, x);
  reference.apply(b, x_ref);
  CHECK((x - x_true).norm() / x_true.norm() < 1e-10);
  CHECK((x - x_ref).norm() / x_ref.norm() < 1e-12);
  for (double& v : A.values()) v *= 2.0;
  serial.update();
  serial.apply(b, x);
  CHECK((2.0 * x - x_true).norm() / x_true.norm() < 1e-10);
  CHECK(omp_get_max_active_levels() == levels);
  // OpenMP regions after it still run on every thread.
  int team = 0;
#pragma omp parallel
  {
#pragma omp single
    team = omp_get_num_threads();
  }
  CHECK(team == omp_get_max_threads());
}

TEST_CASE("CHOLMOD factorisations on several threads at once leave each thread's OpenMP setting",
          "[sparse][cholmod]") {
  // The serial scope's setting belongs to the calling thread: factorisations that overlap on two
  // threads must leave each thread's own setting, and its parallel regions' team, as they were.
  const Bcsr A = spring_lattice(8);
  const Vector x_true = smooth_field(8);
  const Vector b = A.to_csr().to_eigen() * x_true;
  const int levels = omp_get_max_active_levels();
  struct Seen {
    int levels_before = -1, levels_after = -1, team_before = -1, team_after = -1;
    double error = 1.0;
  };
  auto team_size = [] {
    int team = 0;
#pragma omp parallel num_threads(2)
    {
#pragma omp single
      team = omp_get_num_threads();
    }
    return team;
  };
  std::vector<Seen> seen(2);
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t)
    threads.emplace_back([&, t] {
      Seen& s = seen[t];
      s.levels_before = omp_get_max_active_levels();
      s.team_before = team_size();
      CholmodSolver solver("metis", 1);
      solver.setup(A);
      for (int i = 0; i < 20; ++i) solver.update();
      Vector x;
      solver.apply(b, x);
      s.error = (x - x_true).norm() / x_true.norm();
      s.levels_after = omp_get_max_active_levels();
      s.team_after = team_size();
    });
  for (std::thread& t : threads) t.join();
  for (const Seen& s : seen) {
    CHECK(s.error < 1e-10);
    CHECK(s.levels_after == s.levels_before);
    CHECK(s.team_after == s.team_before);
  }
  CHECK(omp_get_max_active_levels() == levels);
}

TEST_CASE("CHOLMOD reports a matrix that is not positive definite", "[sparse][cholmod][errors]") {
  Csr A = spring_lattice(3).to_csr();
  CholmodSolver chol;
  chol.analyze(A);
  A.values()[0] = -100.0;  // entry (0,0)
  CHECK_THROWS_WITH(chol.factorize(A), Catch::Contains("not positive definite"));
  Vector x;
  CHECK_THROWS_WITH(chol.apply(Vector::Ones(A.rows()), x), Catch::Contains("before a successful"));
}

TEST_CASE("CHOLMOD on a matrix that is not symmetric: the failure says so, or the solve's check holds",
          "[sparse][cholmod][errors]") {
  // [[1, 3], [0, 1]] and its transpose: one triangle read as a symmetric matrix is indefinite (the
  // failure names the asymmetry), the other is the identity, whose solve the refinement against the
  // given matrix corrects; no answer passes unless it solves the given matrix.
  for (const bool upper : {true, false}) {
    CAPTURE(upper);
    const Csr A = Csr::from_triplets(2, 2, {{0, 0, 1.0}, {1, 1, 1.0}, upper ? Triplet(0, 1, 3.0) : Triplet(1, 0, 3.0)});
    CholmodSolver chol;
    bool refused = false;
    try {
      chol.setup(A);
    } catch (const Error& e) {
      refused = true;
      CHECK_THAT(e.what(), Catch::Contains("not positive definite") && Catch::Contains("not symmetric either"));
    }
    if (!refused) {
      Vector x = Vector::Zero(2), r;
      try {
        chol.solve(Vector::Ones(2), x);
        A.residual(Vector::Ones(2), x, r);
        CHECK(r.norm() <= 1e-6 * std::sqrt(2.0));
      } catch (const SolveError&) {
        SUCCEED("the solve's check refused the answer");
      }
    }
  }
}

TEST_CASE("CHOLMOD refuses a pattern other than the analysed one", "[sparse][cholmod][errors]") {
  CholmodSolver chol;
  CHECK_THROWS_WITH(chol.factorize(spring_lattice(3).to_csr()), Catch::Contains("before analyze"));
  chol.analyze(spring_lattice(3).to_csr());
  CHECK_THROWS_AS(chol.factorize(spring_lattice(4).to_csr()), InputError);
}

TEST_CASE("CHOLMOD as a Solver on BCSR: setup once, update() copies new values into the kept pattern",
          "[sparse][cholmod][solver]") {
  Bcsr A = spring_lattice(6);
  const Vector x_true = smooth_field(6);
  const Vector b = A.to_csr().to_eigen() * x_true;
  CholmodSolver chol;
  chol.setup(A);
  Vector x;
  const SolveResult r = chol.solve(b, x);
  CHECK(r.status == SolveStatus::converged);
  CHECK(r.true_rel_residual < 1e-12);
  CHECK((x - x_true).norm() / x_true.norm() < 1e-10);
  for (double& v : A.values()) v *= 4.0;
  chol.update();
  chol.apply(b, x);
  CHECK((4.0 * x - x_true).norm() / x_true.norm() < 1e-10);
  CHECK_THROWS_WITH(CholmodSolver().update(), Catch::Contains("before setup"));
}

TEST_CASE("Bcsr::copy_values_to refreshes a to_csr() copy in place", "[sparse][formats]") {
  Bcsr A = spring_lattice(4);
  Csr C = A.to_csr();
  const auto pattern = C.shared_pattern();
  for (size_t k = 0; k < A.values().size(); ++k) A.values()[k] = 0.5 * static_cast<double>(k % 17) - 3.0;
  A.copy_values_to(C);
  CHECK(C.shared_pattern() == pattern);
  const Csr fresh = A.to_csr();
  CHECK(C.values() == fresh.values());
  Csr other = spring_lattice(3).to_csr();
  CHECK_THROWS_AS(A.copy_values_to(other), InputError);
}

namespace {
/// The 7-point Laplacian on an n^3 grid without boundary conditions (singular: the constants are
/// its kernel) plus shift * I: positive definite on paper, numerically singular for shift 1e-14.
Csr neumann_laplacian(index_t n, double shift) {
  std::vector<Triplet> t;
  auto id = [n](index_t i, index_t j, index_t k) { return (k * n + j) * n + i; };
  for (index_t k = 0; k < n; ++k)
    for (index_t j = 0; j < n; ++j)
      for (index_t i = 0; i < n; ++i) {
        const index_t r = id(i, j, k);
        double diag = shift;
        const index_t nb[6][3] = {{i - 1, j, k}, {i + 1, j, k}, {i, j - 1, k}, {i, j + 1, k}, {i, j, k - 1}, {i, j, k + 1}};
        for (const auto& q : nb) {
          if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= n || q[1] >= n || q[2] >= n) continue;
          t.emplace_back(r, id(q[0], q[1], q[2]), -1.0);
          diag += 1.0;
        }
        t.emplace_back(r, r, diag);
      }
  return Csr::from_triplets(n * n * n, n * n * n, t);
}
}  // namespace

TEST_CASE("a direct solve is checked: a numerically singular system is a SolveError, not a success",
          "[sparse][cholmod]") {
  const Csr A = neumann_laplacian(12, 1e-14);
  Vector b(A.rows());
  for (index_t i = 0; i < A.rows(); ++i) b[i] = std::sin(0.37 * i) + 0.5;  // not orthogonal to the kernel
  CholmodSolver chol;
  chol.setup(A);  // the factorisation itself succeeds: every pivot is positive
  Vector x;
  try {
    chol.solve(b, x);
    FAIL("the solve of a numerically singular system reported success");
  } catch (const SolveError& e) {
    CHECK(e.result.status == SolveStatus::stagnated);
    CHECK(e.result.true_rel_residual > 1e-6);
    // the solve and its refinement steps that helped (at most two; one that did not is undone)
    CHECK(e.result.iterations >= 1);
    CHECK(e.result.iterations <= 3);
    CHECK_THAT(e.what(), Catch::Contains("after the solve and " + std::to_string(e.result.iterations - 1) +
                                         " refinement step"));
    CHECK_THAT(e.what(), Catch::Contains("singular") && Catch::Contains("above the tolerance 1e-06"));
  }
  // throw_on_failure=false: the status says it, and the residual reported is the true one.
  CholmodParams p;
  p.check.throw_on_failure = false;
  CholmodSolver quiet(p);
  quiet.setup(A);
  x.resize(0);
  const SolveResult r = quiet.solve(b, x);
  CHECK_FALSE(r.ok());
  Vector res;
  A.residual(b, x, res);
  CHECK(r.true_rel_residual == Approx(res.norm() / b.norm()).epsilon(1e-6));
}

TEST_CASE("a direct solve refines to its tolerance and ignores the initial guess", "[sparse][cholmod]") {
  const Csr A = neumann_laplacian(10, 1.0);  // well conditioned
  Vector b(A.rows());
  for (index_t i = 0; i < A.rows(); ++i) b[i] = std::cos(0.21 * i);
  CholmodParams p;
  p.check.tol = 1e-14;
  CholmodSolver chol(p);
  chol.setup(A);
  Vector x = Vector::Constant(A.rows(), 1e6);  // a bad guess changes nothing
  const SolveResult r = chol.solve(b, x);
  CHECK(r.status == SolveStatus::converged);
  CHECK(r.true_rel_residual <= 1e-14);
  Vector res;
  A.residual(b, x, res);
  CHECK(res.norm() / b.norm() <= 1e-14);
  CHECK(r.initial_residual == Approx(b.norm()));
}
