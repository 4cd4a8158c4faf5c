// The README's first example: a Matrix Market system solved through the solver factory.
//   solve_matrix_market A.mtx [b.mtx] [method]      (b: all ones when not given; method: cg)
#include <pmg/solvers.hpp>              // make_solver and every built-in method
#include <pmg/sparse/matrix_market.hpp>

#include <cstdio>
#include <string>

int main(int argc, char** argv) try {
  pmg::register_all_solvers();          // multigrid, CHOLMOD, hypre, PETSc (and GPU) methods
  const pmg::Csr A = pmg::read_matrix_market(argc > 1 ? argv[1] : "A.mtx");
  const pmg::Vector b = argc > 2 ? pmg::read_matrix_market_vector(argv[2]) : pmg::Vector::Ones(A.rows());
  const std::string method = argc > 3 ? argv[3] : "cg";
  auto solver = pmg::make_solver(pmg::Config::from_pairs(
      {"method=" + method, "preconditioner=block-jacobi", "tol=1e-8"}, "example"));
  solver->setup(A);
  pmg::Vector x;                        // empty: starts from zero
  const pmg::SolveResult r = solver->solve(b, x);
  std::printf("%s: %s in %d iterations, true relative residual %.2e\n", solver->name().c_str(),
              pmg::to_string(r.status), r.iterations, r.true_rel_residual);
  return r.ok() ? 0 : 1;  // converged (or a preconditioner's one correction: completed)
} catch (const pmg::Error& e) {
  std::fprintf(stderr, "solve_matrix_market: %s\n", e.what());
  return 2;
}
