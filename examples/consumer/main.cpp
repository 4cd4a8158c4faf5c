// Hands pmgkit a matrix of your own (here an Eigen sparse matrix: the 1-D Laplacian), solves it
// with Jacobi-preconditioned CG and with CHOLMOD, and checks the two agree.
#include <pmg/sparse/cholmod_solver.hpp>
#include <pmg/sparse/krylov.hpp>

#include <iostream>

int main() {
  const int n = 100;
  Eigen::SparseMatrix<double> L(n, n);
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0);
    if (i > 0) t.emplace_back(i, i - 1, -1.0);
    if (i + 1 < n) t.emplace_back(i, i + 1, -1.0);
  }
  L.setFromTriplets(t.begin(), t.end());

  const pmg::Csr A = pmg::Csr::from_eigen(L);
  const pmg::Vector b = pmg::Vector::Ones(n);
  pmg::Vector x_cg = pmg::Vector::Zero(n), x_chol;

  pmg::KrylovParams params;
  params.rel_tol = 1e-12;
  const pmg::JacobiPreconditioner M(A);
  const pmg::SolveResult r = pmg::pcg(A, &M, b, x_cg, params);

  pmg::CholmodSolver chol;
  chol.compute(A);
  chol.solve(b, x_chol);

  const double diff = (x_cg - x_chol).norm() / x_chol.norm();
  std::cout << "PCG: " << pmg::to_string(r.status) << " in " << r.iterations
            << " iterations; |x_pcg - x_cholmod| / |x_cholmod| = " << diff << "\n";
  return diff < 1e-9 ? 0 : 1;
}
