// pmg/sparse/krylov.hpp — conjugate gradients: CG, PCG with any Preconditioner, and the merged CG
// (MCG) of Weber et al. 2013, whose three fused steps are the CPU reference of the GPU version.
//
// Stopping: relative residual ||r_i||/||b|| <= rel_tol (||r_0|| where b = 0). When the recursive residual says so, the
// true residual b - A x is computed; if it disagrees (lost accuracy) the residual is replaced and
// the iteration goes on, and a second disagreement is reported as stagnation. Breakdown (non-
// positive curvature: the operator or preconditioner is not SPD), divergence, NaN/Inf, and
// stagnation end the solve with a SolveError (or only a status, with throw_on_failure = false).
#pragma once

#include "pmg/sparse/monitor.hpp"
#include "pmg/sparse/operator.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/preconditioners.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>

namespace pmg {

/// The stopping keys shared by every iterative method, over the caller's own fields: tol (< 1),
/// rhs_floor, max_iterations, throw_on_failure; their one definition (ranges, help).
void visit_stopping_keys(ParamVisitor& v, double& tol, double& rhs_floor, int& max_iterations,
                         bool& throw_on_failure);

/// Stopping and failure rules of the CG-type methods (and the stationary multigrid iteration);
/// solver keys: see visit().
struct KrylovParams {
  /// Converged when ||r_i|| <= rel_tol ||b|| (||r_0|| where b = 0; key `tol`, in [0, 1)), as in
  /// SciPy and PETSc: a start that meets it ends at once. The true residual must then be within
  /// 2 rel_tol.
  double rel_tol = 1e-8;
  /// Also converged when ||r|| <= abs_tol (0: off). A warm-started time step can begin so close to
  /// its solution that rel_tol ||r_0|| lies below rounding; a floor such as 1e-12 ||b|| ends it.
  double abs_tol = 0.0;
  /// Also converged when ||r|| <= rhs_floor ||b|| (0: off): the rounding floor of warm-started
  /// solves, independent of the size of the right-hand side (simulations use 1e-12).
  double rhs_floor = 0.0;
  /// Iteration limit: reaching it unconverged is SolveStatus::iteration_limit (a failure).
  int max_iterations = 10000;
  /// Run exactly max_iterations (the seed's "20 CG iterations"); only failures stop it early.
  bool fixed_iterations = false;
  /// A relative residual above this is divergence.
  double divergence_limit = 1e6;
  /// Stagnation: the residual did not drop below stagnation_factor x its last reference value
  /// within this many iterations (0 disables) and, for CG-type methods, the energy norm of the
  /// error (which CG decreases monotonically by α rᵀz per iteration) fell by less than 1e-8 of its
  /// total decrease over the same window. The residual alone is no test for CG: on hard problems
  /// it can stay above its initial value for thousands of iterations while CG progresses steadily.
  int stagnation_window = 1000;
  /// Progress means a relative residual below stagnation_factor times the last reference value
  /// (see stagnation_window); not a solver key.
  double stagnation_factor = 0.9;
  /// MCG only: read the residual for the convergence test every k iterations (as on a GPU).
  int check_every = 1;
  /// A failed solve (breakdown, divergence, NaN/Inf, stagnation, iteration limit) throws
  /// SolveError; false: it only sets the status of the returned SolveResult.
  bool throw_on_failure = true;
  /// pcg() only: flexible CG for a preconditioner that varies between applications (an inner
  /// solve to a tolerance): beta = -zᵀ(A p) / pᵀ(A p), which A-orthogonalises each direction
  /// against the previous one (Notay, "Flexible conjugate gradients", SIAM J. Sci. Comput. 2000,
  /// truncated to one vector); equal to the standard beta in exact arithmetic when M is fixed. One
  /// more dot product per iteration. Not a factory key: Cg sets it for a nonlinear preconditioner.
  bool flexible = false;
  /// The keys tol, abs_tol, rhs_floor, max_iterations, fixed_iterations, divergence_limit,
  /// stagnation_window and throw_on_failure (check_every is the merged CG's alone:
  /// visit_check_every).
  void visit(ParamVisitor& v);
  /// The stopping keys every iterative method shares (tol, rhs_floor, max_iterations,
  /// throw_on_failure): visit() reads them first; methods with parameters of their own (petsc-mgpcg)
  /// read the same keys through visit_stopping_keys().
  void visit_stopping(ParamVisitor& v);
  /// The key check_every.
  void visit_check_every(ParamVisitor& v);
};

/// Work vectors of one CG-type solve; reused across calls of the same size (no allocation per
/// solve when a solver object keeps one).
struct KrylovWorkspace {
  /// \var q
  /// The operator times the search direction (q = A p).

  /// \var p
  /// The search direction.

  /// The residual (resized by each solve; the other vectors alike).
  Vector r, q, p, z;  ///< the preconditioned residual (unused without a preconditioner)
};

/// Unpreconditioned CG on an SPD operator. x holds the initial guess and receives the solution.
SolveResult cg(const LinearOperator& A, const Vector& b, Vector& x, const KrylovParams& params = {},
               SolveMonitor* monitor = nullptr);

/// Preconditioned CG; M approximates A^{-1} and must be SPD (M == nullptr: plain CG).
SolveResult pcg(const LinearOperator& A, const LinearOperator* M, const Vector& b, Vector& x,
                const KrylovParams& params = {}, SolveMonitor* monitor = nullptr,
                KrylovWorkspace* work = nullptr);

/// Merged CG with block-Jacobi preconditioning, in three fused steps per iteration:
///   (1) q = A s and sigma = s.q                                  (one pass: A, s; writes q)
///   (2) alpha = rho/sigma; x += alpha s; r -= alpha q; z = D^{-1} r; rho' = r.z; rr = r.r
///                                                                (one pass over x, s, r, q, D^{-1})
///   (3) beta = rho'/rho; s = z + beta s                           (one pass over z, s)
/// Vector traffic 16n doubles per iteration besides the matrix, against 21n for the unfused PCG.
/// Mathematically identical to pcg() with BlockJacobiPreconditioner: agrees to round-off.
SolveResult mcg(const LinearOperator& A, const BlockJacobiPreconditioner& M, const Vector& b,
                Vector& x, const KrylovParams& params = {}, SolveMonitor* monitor = nullptr,
                KrylovWorkspace* work = nullptr);

/// What every Krylov Solver around an owned preconditioner shares (Cg, Gmres): the stopping rules,
/// the preconditioner (nullptr: none) set up and updated with the solver, its needs and timings
/// passed on, and apply(b, x) as a solve from x = 0 to the tolerance (a nonlinear map, so a Krylov
/// solver preconditioning an outer one makes that one flexible). Work vectors live in the object.
class PreconditionedKrylov : public Solver {
 public:
  bool is_linear() const override { return false; }
  bool is_symmetric() const override { return false; }
  SolverNeeds needs() const override { return M_ ? M_->needs() : SolverNeeds{}; }
  TimingBreakdown timings() const override { return M_ ? M_->timings() : TimingBreakdown{}; }
  TimingBreakdown setup_timings() const override { return M_ ? M_->setup_timings() : TimingBreakdown{}; }
  void reset_timings() const override {
    if (M_) M_->reset_timings();
  }
  /// The stopping rules, to change between solves (read at each solve).
  KrylovParams& params() { return params_; }
  /// The stopping rules.
  const KrylovParams& params() const { return params_; }
  /// The preconditioner, owned by this solver (nullptr: none).
  Solver* preconditioner() const { return M_.get(); }

 protected:
  /// Takes ownership of the preconditioner.
  PreconditionedKrylov(const KrylovParams& params, std::unique_ptr<Solver> preconditioner)
      : params_(params), M_(std::move(preconditioner)) {}
  /// Sets up the preconditioner on A.
  void setup_impl(const LinearOperator& A) override;
  /// Updates the preconditioner.
  void update_impl() override;
  /// x = the solve of b from x = 0 (an error where it broke down or met NaN).
  void apply_impl(const Vector& b, Vector& x) const override;

  KrylovParams params_;         ///< the stopping rules
  std::unique_ptr<Solver> M_;   ///< the preconditioner (nullptr: none)
};

/// CG as a Solver, preconditioned by any Solver set up on the same matrix (none: plain CG). The
/// preconditioner must be symmetric where it is linear (the constructor refuses one that is not,
/// naming it); a nonlinear one (a multigrid cycle whose lowest level is solved to a tolerance)
/// makes the iteration flexible (KrylovParams::flexible).
/// apply(b, x) solves from x = 0 to the tolerance: a nonlinear map, so a CG preconditioning an
/// outer CG makes that one flexible; it can solve a multigrid cycle's lowest level. Work vectors
/// live in the object.
class Cg final : public PreconditionedKrylov {
 public:
  /// Takes ownership of the preconditioner (nullptr: plain CG), which is set up and updated with
  /// the Cg. Throws InputError when the preconditioner is linear but not symmetric.
  explicit Cg(const KrylovParams& params = {}, std::unique_ptr<Solver> preconditioner = nullptr);
  std::string name() const override;
  /// The preconditioner's description (its name when it has none), or "no preconditioner".
  std::string describe() const override {
    if (!M_) return "no preconditioner";
    const std::string d = M_->describe();
    return d.empty() ? "preconditioner " + M_->name() : d;
  }
  /// Multiply with `op` instead of the set-up matrix (the same matrix in another format, e.g.
  /// BIN-BCSR, while the preconditioner reads the BCSR entries). nullptr: the set-up matrix.
  void set_multiplication_operator(const LinearOperator* op) { spmv_ = op; }
  bool multiply_with(const LinearOperator* op) override {
    spmv_ = op;
    return true;
  }

 private:
  void setup_impl(const LinearOperator& A) override;
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;

  const LinearOperator* spmv_ = nullptr;
  mutable KrylovWorkspace work_;
};

/// The merged CG with its built-in block-Jacobi preconditioner as a Solver.
class MergedCg final : public Solver {
 public:
  /// Not yet set up; setup() needs an operator of 3x3 blocks (size divisible by 3).
  explicit MergedCg(const KrylovParams& params = {}) : params_(params) {}
  std::string name() const override { return "mcg"; }
  bool is_linear() const override { return false; }
  bool is_symmetric() const override { return false; }
  /// The stopping rules, to change between solves (read at each solve).
  KrylovParams& params() { return params_; }
  /// Multiply with `op` instead of the set-up matrix, as Cg::set_multiplication_operator().
  void set_multiplication_operator(const LinearOperator* op) { spmv_ = op; }
  bool multiply_with(const LinearOperator* op) override {
    spmv_ = op;
    return true;
  }
  /// The built-in block-Jacobi preconditioner (set up with the solver).
  const BlockJacobiPreconditioner& preconditioner() const { return M_; }

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override { M_.update(); }
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;
  void apply_impl(const Vector& b, Vector& x) const override;

  KrylovParams params_;
  BlockJacobiPreconditioner M_;
  const LinearOperator* spmv_ = nullptr;
  mutable KrylovWorkspace work_;
};

/// Throws SolveError when an inner solve (a Krylov method used through apply()) produced NaN or
/// broke down; other failures are returned (see Cg::apply).
void require_usable(const SolveResult& r);

/// params with abs_tol raised to rhs_floor ||b|| (the solvers' stopping rule for one solve).
KrylovParams with_rhs_floor(KrylovParams params, const Vector& b);

}  // namespace pmg
