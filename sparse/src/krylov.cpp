#include "pmg/sparse/krylov.hpp"

#include "pmg/sparse/convergence.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <chrono>
#include <limits>

namespace pmg {

namespace {
void check_inputs(const char* method, const LinearOperator& A, const LinearOperator* M,
                  const Vector& b, Vector& x) {
  if (A.rows() != A.cols()) throw InputError(std::string(method) + ": operator is not square");
  if (b.size() != A.rows())
    throw InputError(std::string(method) + ": right-hand side has " + std::to_string(b.size()) +
                     " entries, operator has " + std::to_string(A.rows()) + " rows");
  if (M && (M->rows() != A.rows() || M->cols() != A.cols()))
    throw InputError(std::string(method) + ": preconditioner size does not match the operator");
  if (x.size() != b.size()) x = Vector::Zero(b.size());
  if (!ops::all_finite(b)) throw InputError(std::string(method) + ": right-hand side has NaN/Inf");
  if (!ops::all_finite(x)) throw InputError(std::string(method) + ": initial guess has NaN/Inf");
}
}  // namespace

SolveResult cg(const LinearOperator& A, const Vector& b, Vector& x, const KrylovParams& params,
               SolveMonitor* monitor) {
  return pcg(A, nullptr, b, x, params, monitor);
}

// Textbook PCG (Saad, Alg. 9.1) on the primitives of vector_ops; with M == nullptr, z aliases r.
SolveResult pcg(const LinearOperator& A, const LinearOperator* M, const Vector& b, Vector& x,
                const KrylovParams& params, SolveMonitor* monitor) {
  const char* method = M ? "PCG" : "CG";
  check_inputs(method, A, M, b, x);
  detail::ConvergenceTracker track(method, params, monitor);
  const Eigen::Index n = b.size();
  Vector r(n), q(n), p(n), zbuf(M ? n : 0);
  Vector& z = M ? zbuf : r;
  A.residual(b, x, r);
  if (!track.start(ops::norm2(r))) return track.finish(ops::norm2(r));

  // (Re)starts the search direction from the current residual; returns false on breakdown.
  double rho = 0.0;
  auto restart = [&](int it) {
    if (M) M->apply(r, z);
    p = z;
    rho = ops::dot(r, z);
    return track.check_positive(rho, "r^T M^{-1} r", it);
  };
  if (!restart(0)) return track.finish(ops::norm2(r));
  for (int it = 1; !track.done(); ++it) {
    const double sigma = A.apply_dot(p, q);  // q = A p, sigma = p^T A p
    if (!track.check_positive(sigma, "p^T A p", it)) break;
    const double alpha = rho / sigma;
    ops::axpy(alpha, p, x);
    ops::axpy(-alpha, q, r);
    track.add_energy_decrease(alpha * rho);
    if (track.after_iteration(it, ops::norm2(r))) {
      A.residual(b, x, r);  // recursive residual converged: confirm with the true one
      if (track.accept_true_residual(ops::norm2(r))) break;
      if (!restart(it)) break;
      continue;
    }
    if (track.done()) break;
    if (M) M->apply(r, z);
    const double rho_new = ops::dot(r, z);
    if (!track.check_positive(rho_new, "r^T M^{-1} r", it)) break;
    ops::xpby(z, rho_new / rho, p);  // p = z + beta p
    rho = rho_new;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  A.residual(b, x, q);
  return track.finish(ops::norm2(q));
}

}  // namespace pmg
