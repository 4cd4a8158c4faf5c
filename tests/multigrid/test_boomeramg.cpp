#include "pmg/fem/generators.hpp"
#include "pmg/fem/pmg_cycle.hpp"
#include "pmg/multigrid/boomeramg.hpp"

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
};
}  // namespace

TEST_CASE("BoomerAMG-preconditioned CG solves the quadratic bar (also on 2 MPI ranks)", "[multigrid][boomeramg]") {
  Bar bar;
  const Bcsr& A = bar.h.matrix(1);
  const mg::BoomerAMG amg(A.to_csr());
  KrylovParams p;
  p.rel_tol = 1e-8;
  Vector x = Vector::Zero(bar.b.size());
  const SolveResult r = pcg(A, &amg, bar.b, x, p);
  CHECK(r.status == SolveStatus::converged);
  Vector x_cg = Vector::Zero(bar.b.size());
  const SolveResult plain = cg(A, bar.b, x_cg, p);
  CHECK(r.iterations < plain.iterations / 2);  // AMG at least halves the CG iterations
  CHECK((x - x_cg).norm() <= 1e-6 * x_cg.norm());
  if (mg::mpi_rank() == 0)
    std::printf("BoomerAMG-PCG on %d rank(s): %d iterations (CG: %d)\n", mg::mpi_size(), r.iterations,
                plain.iterations);
}

TEST_CASE("BoomerAMG as PMG's lowest-level solver", "[multigrid][boomeramg]") {
  Bar bar;
  const mg::BlockTransfer T(bar.h.prolongation(1));
  std::vector<std::unique_ptr<mg::Smoother>> smoothers;
  smoothers.push_back(std::make_unique<mg::BlockGaussSeidel>(bar.h.matrix(1)));
  const mg::MultigridCycle cycle({&bar.h.matrix(0), &bar.h.matrix(1)}, {&T}, std::move(smoothers),
                                 std::make_unique<mg::BoomerAMGCoarseSolver>(bar.h.matrix(0)));
  Vector x = Vector::Zero(bar.b.size());
  KrylovParams p;
  p.rel_tol = 1e-8;
  p.max_iterations = 200;
  // One AMG cycle is an inexact lowest-level solve: the PMG cycle still converges, more slowly.
  const SolveResult r = mg::mgpcg(bar.h.matrix(1), cycle, bar.b, x, p);
  CHECK(r.status == SolveStatus::converged);
}

TEST_CASE("BoomerAMG refuses a matrix with NaN", "[multigrid][boomeramg][errors]") {
  Csr A = Csr::from_triplets(3, 3, {{0, 0, 1.0}, {1, 1, std::nan("")}, {2, 2, 1.0}});
  CHECK_THROWS_WITH(mg::BoomerAMG(A), Catch::Contains("NaN"));
}
