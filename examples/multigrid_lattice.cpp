// Multigrid without pmg::fem: you bring the level matrices and the transfer operators.
//
// Geometric multigrid on the spring lattice: levels are lattices of 33³, 17³, 9³ nodes; P is
// trilinear interpolation from a lattice to the next finer one, coarse matrices are Galerkin
// products R A P with R = Pᵀ, the smoother is multicolour block Gauss–Seidel, the lowest level
// is solved by CHOLMOD. Then PMG-style stationary cycles and MGPCG solve A x = b.
//
//   1. Fine matrix and right-hand side (any BCSR / CSR matrix of yours works the same way).
//   2. Scalar prolongations between node sets (BlockTransfer applies them to all 3 components).
//   3. Coarse operators: Galerkin products.
//   4. Smoothers and the lowest-level solver; the cycle.
//   5. Solve, with the same stopping rules and monitor as the Krylov solvers.
#include <pmg/multigrid/cycle.hpp>
#include <pmg/sparse/generators.hpp>

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
  // 1.
  const index_t n = 33;
  const Bcsr A2 = spring_lattice(n);
  Vector b;
  A2.apply(smooth_field(n), b);

  // 2. fine 33 <- 17 <- 9
  const mg::BlockTransfer T1(trilinear(9)), T2(trilinear(17));

  // 3.
  const Bcsr A1 = mg::galerkin_product(T2, A2);
  const Bcsr A0 = mg::galerkin_product(T1, A1);

  // 4.
  std::vector<std::unique_ptr<mg::Smoother>> smoothers;
  smoothers.push_back(std::make_unique<mg::BlockGaussSeidel>(A1));
  smoothers.push_back(std::make_unique<mg::BlockGaussSeidel>(A2));
  const mg::MultigridCycle cycle({&A0, &A1, &A2}, {&T1, &T2}, std::move(smoothers),
                                 std::make_unique<mg::CholmodCoarseSolver>(A0));

  // 5.
  KrylovParams params;
  params.rel_tol = 1e-8;
  Vector x = Vector::Zero(b.size()), y = x, z = x;
  const SolveResult r = mg::multigrid_solve(A2, cycle, b, x, params);
  const SolveResult m = mg::mgpcg(A2, cycle, b, y, params);
  const SolveResult c = cg(A2, b, z, params);
  std::printf("%ld unknowns: multigrid %d cycles, MGPCG %d iterations, CG %d iterations\n",
              static_cast<long>(b.size()), r.iterations, m.iterations, c.iterations);
  return r.ok() && m.ok() && r.iterations < c.iterations / 5 ? 0 : 1;
}
