// The README's first example: a Matrix Market system solved through the solver factory. Run from
// the repository root (the data is examples/data/); the README shows the part between the markers.
//   solve_matrix_market [A.mtx [b.mtx [method]]]   (b: all ones when A is given alone; method: cg)
#include <cstdio>
#include <string>

// README begin
#include <pmg/solvers.hpp>              // make_solver and every built-in method
#include <pmg/sparse/matrix_market.hpp>

int solve(const std::string& matrix, const std::string& rhs, const std::string& method) {
  pmg::register_all_solvers();          // multigrid, CHOLMOD, hypre, PETSc (and GPU) methods
  const pmg::Csr A = pmg::read_matrix_market(matrix);              // a cubic cantilever, 900 unknowns
  const pmg::Vector b = pmg::read_matrix_market_vector(rhs);
  auto solver = pmg::make_solver(pmg::Config::from_pairs(
      {"method=" + method, "preconditioner=block-jacobi", "tol=1e-8"}, "example"));
  solver->setup(A);                     // a Csr that carries 3x3 blocks is read as blocks
  pmg::Vector x;                        // empty: starts from zero
  const pmg::SolveResult r = solver->solve(b, x);   // status, iterations, true residual
  std::printf("%s: %s in %d iterations, true relative residual %.1e\n", solver->name().c_str(),
              pmg::to_string(r.status), r.iterations, r.true_rel_residual);
  return r.ok() ? 0 : 1;
}

int main() try {
  return solve("examples/data/elasticity.mtx", "examples/data/elasticity_b.mtx", "cg");
} catch (const pmg::Error& e) {         // InputError (bad input) or SolveError (a failed solve)
  std::fprintf(stderr, "error: %s\n", e.what());
  return 2;
}
// README end
