#include "pmg/sparse/krylov.hpp"

#include "pmg/sparse/convergence.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <algorithm>
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
                const KrylovParams& params, SolveMonitor* monitor, KrylovWorkspace* work) {
  const char* method = M ? "PCG" : "CG";
  check_inputs(method, A, M, b, x);
  detail::ConvergenceTracker track(method, params, monitor);
  const Eigen::Index n = b.size();
  KrylovWorkspace local;
  KrylovWorkspace& w = work ? *work : local;
  w.r.resize(n), w.q.resize(n), w.p.resize(n);
  if (M) w.z.resize(n);
  Vector &r = w.r, &q = w.q, &p = w.p;
  Vector& z = M ? w.z : r;
  A.residual(b, x, r);
  if (!track.start(ops::norm2(r), ops::norm2(b))) return track.finish(ops::norm2(r));

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
    // Standard: beta = rho_new / rho. Flexible: beta = -zᵀq / sigma (q = A p).
    const double beta = params.flexible && M ? -ops::dot(z, q) / sigma : rho_new / rho;
    ops::xpby(z, beta, p);  // p = z + beta p
    rho = rho_new;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  A.residual(b, x, q);
  return track.finish(ops::norm2(q));
}

void visit_stopping_keys(ParamVisitor& v, double& tol, double& rhs_floor, int& max_iterations,
                         bool& throw_on_failure) {
  v.real("tol", tol, 0.0, 1.0, "relative residual ||b - A x|| / ||b|| to reach (< 1; ||r0|| is the reference where b = 0)");
  if (v.reading() && !(tol < 1.0)) v.fail("tol", "must be < 1");
  v.real("rhs_floor", rhs_floor, 0.0, 1.0,
         "also converged when ||r|| <= rhs_floor ||b||: the rounding floor of warm-started solves");
  v.integer("max_iterations", max_iterations, 1, std::numeric_limits<int>::max(), "iteration limit");
  v.boolean("throw_on_failure", throw_on_failure,
            "a failed solve throws SolveError (false: only its status says so)");
}

void KrylovParams::visit_stopping(ParamVisitor& v) {
  visit_stopping_keys(v, rel_tol, rhs_floor, max_iterations, throw_on_failure);
}

void KrylovParams::visit(ParamVisitor& v) {
  constexpr int kMaxInt = std::numeric_limits<int>::max();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  visit_stopping(v);
  v.real("abs_tol", abs_tol, 0.0, kInf, "also converged when ||r|| <= abs_tol (0: off)");
  int fixed = 0;
  v.integer("fixed_iterations", fixed, 0, kMaxInt,
            "run exactly this many iterations, no tolerance (0: off; excludes max_iterations)");
  if (fixed > 0) {
    if (v.given("max_iterations")) v.fail("fixed_iterations", "give either fixed_iterations or max_iterations");
    max_iterations = fixed;
    fixed_iterations = true;
  }
  v.real("divergence_limit", divergence_limit, 1.0, kInf, "a relative residual above this is divergence");
  v.integer("stagnation_window", stagnation_window, 0, kMaxInt,
            "iterations without progress (residual and energy norm) that count as stagnation (0: off)");
}

void KrylovParams::visit_check_every(ParamVisitor& v) {
  v.integer("check_every", check_every, 1, std::numeric_limits<int>::max(),
            "test convergence every k iterations (as on a GPU)");
}

KrylovParams with_rhs_floor(KrylovParams params, const Vector& b) {
  if (!(params.rhs_floor >= 0.0)) throw InputError("Krylov: rhs_floor must be >= 0");
  params.abs_tol = std::max(params.abs_tol, params.rhs_floor * ops::norm2(b));
  return params;
}

// ---- Cg ------------------------------------------------------------------------------------------

void PreconditionedKrylov::setup_impl(const LinearOperator& A) {
  if (M_) M_->setup(A);
}

void PreconditionedKrylov::update_impl() {
  if (M_) M_->update();
}

void PreconditionedKrylov::apply_impl(const Vector& b, Vector& x) const {
  x.setZero();
  require_usable(solve_impl(b, x, nullptr));
}

Cg::Cg(const KrylovParams& params, std::unique_ptr<Solver> preconditioner)
    : PreconditionedKrylov(params, std::move(preconditioner)) {
  if (M_ && M_->is_linear() && !M_->is_symmetric())
    throw InputError("CG: the preconditioner '" + M_->name() + "' is not symmetric (a restriction "
                     "other than the transposed prolongation, or non-adjoint smoothing); CG needs "
                     "a symmetric one");
  // A preconditioner that varies between applications (a solve to a tolerance inside it): the
  // flexible iteration.
  if (M_ && !M_->is_linear()) params_.flexible = true;
}

std::string Cg::name() const {
  return M_ ? (params_.flexible ? "flexible cg(" : "cg(") + M_->name() + ")" : "cg";
}

void Cg::setup_impl(const LinearOperator& A) {
  PreconditionedKrylov::setup_impl(A);
  const Eigen::Index n = A.rows();
  work_.r.resize(n), work_.q.resize(n), work_.p.resize(n);
  if (M_) work_.z.resize(n);
}

SolveResult Cg::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  const LinearOperator& A = spmv_ ? *spmv_ : system();
  return pcg(A, M_.get(), b, x, with_rhs_floor(params_, b), monitor, &work_);
}

void require_usable(const SolveResult& r) {
  // With throw_on_failure off an inner solve that stopped early (iteration limit, stagnation) is
  // still a usable correction that the outer iteration judges; NaN or a breakdown is not.
  if (r.status == SolveStatus::non_finite || r.status == SolveStatus::breakdown) throw SolveError(r);
}

}  // namespace pmg
