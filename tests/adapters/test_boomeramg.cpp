#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/hypre/boomeramg.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/cholmod/cholmod_solver.hpp"

#include <catch2/catch.hpp>

#include <cstdio>

using namespace pmg;
using namespace pmg::fem;

namespace {
struct Bar {
  TetMesh mesh = box_mesh_24(10, 2, 2, 1.0, 0.2, 0.2);
  DegreeHierarchy h{mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }};
  Vector b;
  Bar() {
    h.assemble(nullptr);
    b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
  }
  /// A factory-built solver on the bar's levels, set up on the finest matrix.
  std::unique_ptr<Solver> build(std::vector<std::string> options) const {
    options.push_back("tol=1e-8");
    options.push_back("max_iterations=200");
    options.push_back("operator=assembled");  // the lowest levels compared under the assembled cycle
    SolverContext ctx;
    ctx.levels = &h;
    auto s = make_solver(Config::from_pairs(options, "test"), ctx);
    s->setup(h.matrix(1));
    return s;
  }
};
}  // namespace

TEST_CASE("BoomerAMG-preconditioned CG solves the quadratic bar (also on 2 MPI ranks)", "[multigrid][boomeramg]") {
  Bar bar;
  const Bcsr& A = bar.h.matrix(1);
  const mg::BoomerAMG amg(A, {});
  KrylovParams p;
  p.rel_tol = 1e-8;
  Vector x = Vector::Zero(bar.b.size());
  const SolveResult r = pcg(A, &amg, bar.b, x, p);
  CHECK(r.status == SolveStatus::converged);
  Vector x_cg = Vector::Zero(bar.b.size());
  const SolveResult plain = cg(A, bar.b, x_cg, p);
  CHECK(r.iterations < plain.iterations / 2);  // AMG at least halves the CG iterations
  CHECK((x - x_cg).norm() <= 1e-6 * x_cg.norm());
  if (mpi::rank() == 0)
    std::printf("BoomerAMG-PCG on %d rank(s): %d iterations (CG: %d)\n", mpi::size(), r.iterations,
                plain.iterations);
}

TEST_CASE("BoomerAMG as PMG's lowest-level solver", "[multigrid][boomeramg]") {
  Bar bar;
  Vector x = Vector::Zero(bar.b.size());
  // One AMG cycle is an inexact lowest-level solve: the PMG cycle still converges, more slowly.
  const SolveResult r = bar.build({"method=mgpcg", "lowest_level=boomeramg"})->solve(bar.b, x);
  CHECK(r.status == SolveStatus::converged);
}

TEST_CASE("BoomerAMG lowest levels: V-cycles keep the cycle symmetric for MGPCG, CG on top restores stationary PMG", "[multigrid][boomeramg]") {
  Bar bar;  // slender (10x2x2): its bending modes are what one AMG V-cycle contracts slowly
  const Bcsr& A = bar.h.matrix(1);
  Vector x_ref = Vector::Zero(bar.b.size());
  const SolveResult ref = bar.build({"method=pmg"})->solve(bar.b, x_ref);  // CHOLMOD on the linear level
  REQUIRE(ref.status == SolveStatus::converged);

  SECTION("fixed V-cycles: a symmetric cycle, MGPCG converges; more V-cycles, fewer iterations") {
    int previous = 1 << 30;
    for (int cycles : {1, 4}) {
      const auto cycle = bar.build({"method=pmg", "lowest_level=boomeramg",
                                    "lowest_level.cycles=" + std::to_string(cycles)});
      INFO(cycles << " AMG V-cycles per linear-level solve");
      const Vector u = Vector::Random(A.rows()), v = Vector::Random(A.rows());
      Vector Cu, Cv;
      cycle->apply(u, Cu);
      cycle->apply(v, Cv);
      CHECK(std::abs(Cu.dot(v) - u.dot(Cv)) <= 1e-10 * Cu.norm() * v.norm());
      Vector y = Vector::Zero(bar.b.size());
      const SolveResult r = bar.build({"method=mgpcg", "cycles=1", "lowest_level=boomeramg",
                                       "lowest_level.cycles=" + std::to_string(cycles)})
                                ->solve(bar.b, y);
      CHECK(r.status == SolveStatus::converged);
      CHECK((y - x_ref).norm() <= 1e-6 * x_ref.norm());
      CHECK(r.iterations < previous);
      previous = r.iterations;
    }
  }
  SECTION("CG to 1e-1 on the linear level: stationary PMG within two cycles of the exact lowest level") {
    const auto pmg = bar.build({"method=pmg", "lowest_level=boomeramg-pcg", "lowest_level.tol=0.1"});
    Vector x = Vector::Zero(bar.b.size());
    const SolveResult r = pmg->solve(bar.b, x);
    INFO("PMG cycles: " << r.iterations << " (CHOLMOD lowest level: " << ref.iterations << ")");
    CHECK(r.status == SolveStatus::converged);
    CHECK(r.iterations <= ref.iterations + 2);
    CHECK((x - x_ref).norm() <= 1e-6 * x_ref.norm());
    // The inner CG makes the cycle depend on its input: MGPCG refuses it.
    CHECK_FALSE(pmg->is_symmetric());
    CHECK_THROWS_AS(bar.build({"method=mgpcg", "lowest_level=boomeramg-pcg"}), InputError);
    // update() (as after a time step's re-assembly) redoes the AMG set-up; on unchanged values
    // the refreshed cycle must behave exactly as the first one.
    pmg->update();
    Vector x2 = Vector::Zero(bar.b.size());
    CHECK(pmg->solve(bar.b, x2).iterations == r.iterations);
  }
  SECTION("a tolerance outside [0, 1) is refused, naming the key") {
    CHECK_THROWS_WITH(bar.build({"method=pmg", "lowest_level=boomeramg-pcg", "lowest_level.tol=1.5"}),
                      Catch::Contains("lowest_level.tol"));
    CHECK_THROWS_WITH(bar.build({"method=pmg", "lowest_level=boomeramg-pcg", "lowest_level.tol=nan"}),
                      Catch::Contains("lowest_level.tol"));
  }
}

TEST_CASE("BoomerAMG refuses a matrix with NaN", "[multigrid][boomeramg][errors]") {
  Csr A = Csr::from_triplets(3, 3, {{0, 0, 1.0}, {1, 1, std::nan("")}, {2, 2, 1.0}});
  CHECK_THROWS_WITH(mg::BoomerAMG(A, {}), Catch::Contains("NaN"));
}

TEST_CASE("any solver composes with BoomerAMG: MGPCG on a BoomerAMG lowest level with Chebyshev smoothing",
          "[multigrid][boomeramg][factory]") {
  Bar bar;
  const Bcsr& A = bar.h.matrix(1);
  CholmodSolver chol;
  chol.setup(A);
  Vector x_ref;
  chol.apply(bar.b, x_ref);
  Vector x = Vector::Zero(bar.b.size());
  const SolveResult r =
      bar.build({"method=mgpcg", "lowest_level=boomeramg", "smoother=chebyshev", "smoother.degree=3"})->solve(bar.b, x);
  CHECK(r.status == SolveStatus::converged);
  CHECK((x - x_ref).norm() <= 1e-6 * x_ref.norm());
}
