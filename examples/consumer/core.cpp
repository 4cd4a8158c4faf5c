// A project that needs only the solver core (pmg::sparse): a matrix of its own solved by the
// factory's core methods. It links no MPI, hypre, PETSc or CHOLMOD (the install test checks its
// shared-library dependencies).
#include <pmg/sparse/factory.hpp>

#include <iostream>

int main() {
  const int n = 300;  // the 1-D Laplacian, three unknowns per node
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0);
    if (i >= 3) t.emplace_back(i, i - 3, -1.0);
    if (i + 3 < n) t.emplace_back(i, i + 3, -1.0);
  }
  Eigen::SparseMatrix<double> L(n, n);
  L.setFromTriplets(t.begin(), t.end());
  const pmg::Csr A = pmg::Csr::from_eigen(L);
  const pmg::Vector b = pmg::Vector::Ones(n);
  int failures = 0;
  for (const char* method : {"cg", "jacobi-pcg", "block-jacobi-pcg"}) {
    auto solver = pmg::make_solver(pmg::Config::from_pairs({std::string("method=") + method, "tol=1e-10"}, "core"));
    solver->setup(A);
    pmg::Vector x;
    const pmg::SolveResult r = solver->solve(b, x);
    std::cout << method << ": " << pmg::to_string(r.status) << " in " << r.iterations << " iterations\n";
    failures += r.status != pmg::SolveStatus::converged;
  }
  return failures;
}
