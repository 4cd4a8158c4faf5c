// Multigrid without pmg::fem: you bring the level matrices and the prolongations.
//
// Geometric multigrid on the spring lattice: levels are lattices of 33³, 17³, 9³ nodes; P is
// trilinear interpolation from a lattice to the next finer one, coarse matrices are Galerkin
// products R A P with R = Pᵀ (computed here by you; `coarse_operator=galerkin` would compute them
// from the finest level instead). The solver factory builds the cycle (multicolour block
// Gauss–Seidel, CHOLMOD on the lowest level by default), stationary multigrid and MGPCG.
//
//   1. Fine matrix and right-hand side (any BCSR matrix of yours works the same way).
//   2. Scalar prolongations between node sets (applied to all 3 components).
//   3. Coarse operators: Galerkin products; the levels handed to a StoredLevels.
//   4. Solvers from options (key=value or JSON), set up on the finest matrix.
//   5. Solve, with the same stopping rules and monitor as every other solver.
#include <pmg/multigrid/factory.hpp>
#include <pmg/multigrid/levels.hpp>
#include <pmg/multigrid/transfer.hpp>
#include <pmg/sparse/generators.hpp>
#include <pmg/sparse/krylov.hpp>

#include <cstdio>

using namespace pmg;

namespace {
/// Trilinear interpolation from an m³ lattice to the (2m-1)³ lattice on the same cube.
Csr trilinear(index_t m) {
  const index_t n = 2 * m - 1;
  std::vector<Triplet> t;
  for (index_t k = 0; k < n; ++k)
    for (index_t j = 0; j < n; ++j)
      for (index_t i = 0; i < n; ++i) {
        const index_t fine = (k * n + j) * n + i;
        // Each fine index is a coarse node (even) or the midpoint of two (odd).
        for (index_t dk = 0; dk <= k % 2; ++dk)
          for (index_t dj = 0; dj <= j % 2; ++dj)
            for (index_t di = 0; di <= i % 2; ++di) {
              const index_t coarse = ((k / 2 + dk) * m + j / 2 + dj) * m + i / 2 + di;
              const double w = 1.0 / ((1 << (k % 2)) * (1 << (j % 2)) * (1 << (i % 2)));
              t.emplace_back(fine, coarse, w);
            }
      }
  return Csr::from_triplets(n * n * n, m * m * m, t);
}
}  // namespace

int main() {
  mg::register_solvers();  // the multigrid methods join the core's in the factory
  // 1.
  const index_t n = 33;
  Bcsr A2 = spring_lattice(n);
  Vector b;
  A2.apply(smooth_field(n), b);

  // 2. fine 33 <- 17 <- 9
  Csr P1 = trilinear(9), P2 = trilinear(17);

  // 3.
  Bcsr A1 = mg::galerkin_product(mg::BlockTransfer(P2), A2);
  Bcsr A0 = mg::galerkin_product(mg::BlockTransfer(P1), A1);
  const mg::StoredLevels levels({A0, A1, A2}, {P1, P2});

  // 4.
  SolverContext ctx;
  ctx.levels = &levels;
  auto pmg = make_solver(Config::from_pairs({"method=pmg", "tol=1e-8"}, "example"), ctx);
  auto mgpcg = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-8"}, "example"), ctx);
  auto cg = make_solver(Config::from_pairs({"method=cg", "tol=1e-8"}, "example"));
  const Bcsr& A = levels.matrix(2);
  for (Solver* s : {pmg.get(), mgpcg.get(), cg.get()}) s->setup(A);

  // 5.
  Vector x = Vector::Zero(b.size()), y = x, z = x;
  const SolveResult r = pmg->solve(b, x);
  const SolveResult m = mgpcg->solve(b, y);
  const SolveResult c = cg->solve(b, z);
  std::printf("%ld unknowns: multigrid %d cycles, MGPCG %d iterations, CG %d iterations\n",
              static_cast<long>(b.size()), r.iterations, m.iterations, c.iterations);
  return r.ok() && m.ok() && r.iterations < c.iterations / 5 ? 0 : 1;
}
