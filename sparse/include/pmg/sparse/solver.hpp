// pmg/sparse/solver.hpp — the one component interface: everything that approximates A⁻¹.
//
// Krylov methods, preconditioners, smoothers, multigrid cycles, direct solvers and AMG are all a
// Solver, and a Solver is a LinearOperator, so any of them can precondition, smooth or solve the
// lowest level of any other (a CG can precondition, a multigrid cycle can be CG's preconditioner,
// CHOLMOD or a CG can solve a cycle's lowest level). Three phases, as Eigen's analyzePattern /
// factorize and MFEM's Solver::SetOperator:
//
//   setup(A)    symbolic and numeric set-up on A: ordering, colouring, slicing, symbolic
//               factorisation, transfer structure, and every work vector. Keeps a reference to A,
//               which must stay alive (and at the same address) until the next setup().
//   update()    A's values changed on the same pattern (a corotational time step): numeric
//               set-up only (refactorisation, inverted diagonal blocks, eigenvalue bounds).
//   apply(b,x)  x = M b, the solver started from x = 0: its use as a preconditioner or smoother.
//   solve(b,x)  improves x (the initial guess) for A x = b and reports what happened.
//
// The public methods check their preconditions and call protected virtuals (Ginkgo's LinOp
// pattern), so an implementation never re-checks sizes. Adding a solver is one class deriving
// from Solver plus one registration in the factory (pmg/sparse/factory.hpp).
//
// Threads. Distinct solvers may be used from different threads at the same time. Calls on one
// solver (setup, update, apply, solve) from several threads are serialised by the solver's own
// lock: they run one at a time, each as if alone, so a shared solver is safe but not parallel.
// The adapters of MPI-based libraries (PETSc with MUMPS, hypre) hold one process-wide lock around
// every call into them, because those libraries keep global state. What a caller must guarantee:
// the matrix (and vectors) a solver reads are not modified while a call runs.
#pragma once

#include "pmg/sparse/monitor.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/csr_view.hpp"
#include "pmg/sparse/operator.hpp"

#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace pmg {

class Bcsr;
class ParamVisitor;

/// How a direct solver's solve() checks its answer (solver keys tol, refinement_steps,
/// throw_on_failure): x = M b, then while ||b - A x|| / ||b|| is above tol, up to refinement_steps
/// steps of iterative refinement x += M (b - A x). Still above tol: status stagnated, a message
/// naming the residual, and SolveError unless throw_on_failure is false. The initial guess is not
/// used, and the residuals are reported relative to ||b||.
struct DirectSolveParams {
  /// Relative residual ||b - A x|| / ||b|| the solve must reach, or else an answer at rounding
  /// level (judge_direct_answer): what a sound factorisation gives on an ill-conditioned system
  /// (the residual's floor, about eps ||A|| ||x|| / ||b||, passes 1e-6 on thin plates) is accepted,
  /// a singular system refused.
  double tol = 1e-6;
  int refinement_steps = 2;   ///< refinement steps taken while above tol
  bool throw_on_failure = true;  ///< a failed check throws SolveError
  /// The keys tol, refinement_steps and throw_on_failure.
  void visit(ParamVisitor& v);
};

/// Below this largest entry of b, Solver::solve() solves the system scaled by a power of two
/// (scale invariance over double's range: no product of the iteration underflows).
inline constexpr double kScaleBelow = 1e-100;
/// Above this largest entry of b, likewise (no product of the iteration overflows).
inline constexpr double kScaleAbove = 1e100;
/// A direct answer x whose residual misses DirectSolveParams::tol is still accepted when its
/// normwise backward error ||r||_inf / (||A||_inf ||x||_inf + ||b||_inf) is at most this (about
/// 4500 eps: x solves a system within rounding of A x = b, as LAPACK's refinement judges) ...
inline constexpr double kDirectBackwardError = 1e-12;
/// ... and its growth ||A||_inf ||x||_inf / ||b||_inf (a lower bound of the condition number)
/// is at most this (1e-3 / eps): a singular system's answer, whose null-space component grows
/// to 1 / eps, is refused.
inline constexpr double kDirectGrowth = 4.5e12;
/// The verdict on a direct answer (see kDirectBackwardError).
struct DirectVerdict {
  bool ok = false;                 ///< accepted
  double rel_residual = 0.0;       ///< ||b - A x||_2 / ||b||_2
  double backward_error = 0.0;     ///< ||r||_inf / (||A||_inf ||x||_inf + ||b||_inf); 0 when not needed
  double growth = 0.0;             ///< ||A||_inf ||x||_inf / ||b||_inf; 0 when not needed
};
/// Judges a direct solve's answer x of A x = b with residual r = b - A x: accepted when
/// ||r|| / ||b|| <= tol, else when the backward error and growth are within the constants above.
/// ||A||_inf comes from the operator's entries (csr_matrix, bcsr_matrix), else from ||A x|| / ||x||.
DirectVerdict judge_direct_answer(const LinearOperator& A, const Vector& b, const Vector& x, const Vector& r,
                                  double tol);

/// What a solver needs of a system's owner besides the finest matrix (the seam between an FEM
/// discretisation and the solvers: one record, prepared by one call on the FEM side).
struct SolverNeeds {
  /// The matrices of the levels below the finest (a geometric multigrid reads them; a Galerkin
  /// cycle forms its own from the finest).
  bool lower_levels = false;
  /// Matrix-free operators on every level above the lowest, the finest included: the solver is
  /// set up on (and multiplies with) the finest level's operator, and no matrix above the lowest
  /// level is assembled.
  bool matrix_free = false;
  /// The provider's level a multigrid solver factorises as its lowest (MultigridParams::
  /// skip_levels): the levels below it are neither read nor prepared.
  int lowest_level = 0;
};

/// A timing breakdown: named parts in seconds over `count` repetitions of a `unit` ("cycle").
struct TimingBreakdown {
  /// (part name, total seconds over all `count` repetitions), in report order.
  std::vector<std::pair<std::string, double>> parts;
  /// Number of repetitions the totals cover (0: nothing timed).
  long count = 0;
  /// What one repetition is, singular ("cycle"); to_string() appends "s" after the count.
  std::string unit;
  /// True when there is nothing to report (no parts or no repetitions).
  bool empty() const { return parts.empty() || count == 0; }
  /// "one cycle T ms: smoothing degree 3 T3 ms, ... (N cycles)" (times per unit); for the units
  /// "set-up" and "update", "set-up T s: transfers T1 s, ..." in seconds; empty when empty().
  std::string to_string() const;
};

/// Anything that approximates A⁻¹ (see the file comment): set up on A, then applied as a
/// preconditioner or smoother (apply()) or run as a solver (solve()).
class Solver : public LinearOperator {
 public:
  Solver() { call_lock_ = &lock_; }
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  /// Short name for tables and messages ("cg", "cholmod", "multigrid", ...).
  virtual std::string name() const = 0;

  /// Symbolic and numeric set-up on A (square). Throws InputError when A's format or entries do not
  /// suit the solver (e.g. a 3x3-block smoother on a scalar matrix) and Error when A is not
  /// positive definite where that is needed.
  void setup(const LinearOperator& A);
  /// A's values changed, the pattern did not: numeric set-up only.
  void update();
  /// Improves x (the initial guess; resized to zero if empty) for A x = b. Iterative solvers stop by
  /// their own parameters; one-shot solvers (direct, preconditioners) apply one correction
  /// x += M (b - A x) and report its true residual. Throws SolveError on failure unless the solver's
  /// parameters say otherwise.
  SolveResult solve(const Vector& b, Vector& x, SolveMonitor* monitor = nullptr) const;

  /// setup() on a matrix held in the caller's arrays (SciPy's, PETSc's, a FEM code's CSR with 32-
  /// or 64-bit indices; pmg/sparse/csr_view.hpp): copied once into a Csr that the solver keeps, so
  /// the caller's arrays may go after the call. A block method then reads it as 3x3 blocks
  /// (BlockInput) exactly as if the Csr had been passed. Throws InputError for an invalid view.
  void setup(const CsrView& A);
  /// update() with new values in the caller's arrays: the same pattern as the view given to
  /// setup(const CsrView&) (the values are copied into the kept Csr, duplicates summed as at
  /// set-up). Throws InputError when the solver was not set up from a view or the pattern differs;
  /// when update() refuses the new values, the kept ones are restored (and set up again) before
  /// the exception propagates.
  void update(const CsrView& A);
  /// solve() on the caller's arrays: b and x hold rows() doubles each (x the initial guess, then
  /// the answer), e.g. a std::vector's data(), an Eigen::Map or a NumPy buffer. Each is copied once
  /// (x back on return, also when a SolveError is thrown): 3n doubles moved, against the
  /// iterations' many passes over the matrix.
  SolveResult solve(const double* b, double* x, SolveMonitor* monitor = nullptr) const;

  /// True after a successful setup() (a setup() that threw leaves it false).
  bool is_set_up() const { return A_ != nullptr; }
  /// The operator of the last setup(). Throws Error before setup().
  const LinearOperator& system() const;
  index_t rows() const override { return n_; }
  index_t cols() const override { return rows(); }

  /// update() runs on the calling thread alone (no OpenMP team, no BLAS threads) and calls back
  /// into no user code, so a multigrid cycle may run it beside its smoothers' updates. Default
  /// false; a direct solver whose refactorisation is serial says true.
  virtual bool update_is_serial() const { return false; }
  /// apply() is a fixed linear map of b (false for a Krylov solve to a tolerance).
  virtual bool is_linear() const { return true; }
  /// apply() is a symmetric map, so that it can precondition CG.
  virtual bool is_symmetric() const { return true; }
  /// What the solver needs from the code that owns the system (an FEM hierarchy), asked once after
  /// it is built: the hierarchy's binding (fem::BoundSystem, DegreeHierarchy::bind) brings exactly
  /// those levels up to date and sets the solver up on its operator. A Krylov method answers for
  /// its preconditioner.
  virtual SolverNeeds needs() const { return {}; }
  /// Multiply with `op` instead of the set-up operator in the solver's own iterations (the same
  /// matrix in another format, e.g. BIN-BCSR while a preconditioner reads the BCSR entries);
  /// nullptr: the set-up operator. Returns false, ignoring op, for a solver that does not multiply
  /// with its system itself (the default).
  virtual bool multiply_with(const LinearOperator* op) {
    (void)op;
    return false;
  }
  /// Where the time of the solves since the last reset_timings() went, by part (a multigrid
  /// cycle's smoothing per level, residuals, transfers, lowest-level solve); empty when the solver
  /// keeps no breakdown. A Krylov method reports its preconditioner's.
  virtual TimingBreakdown timings() const { return {}; }
  /// Starts the breakdown afresh (before a timed solve).
  virtual void reset_timings() const {}
  /// Where the last setup() or update() spent its time, by stage (a multigrid cycle's transfers,
  /// smoothers per level and lowest level), with unit "set-up" or "update" and count 1; empty
  /// when the solver keeps no breakdown. A Krylov method reports its preconditioner's.
  virtual TimingBreakdown setup_timings() const { return {}; }
  /// What set-up chose and found, for reports (settings, hierarchy, ordering, factor size); empty
  /// when there is nothing beyond the name. A Krylov method reports its preconditioner's.
  virtual std::string describe() const { return ""; }

 protected:
  /// The solver's set-up on A, called by setup() with A square (rows() and system() are not yet
  /// valid: use A). Prepares everything apply() needs, work vectors included, and throws
  /// InputError or Error as setup() documents. A outlives the set-up, so it may be kept by
  /// reference.
  virtual void setup_impl(const LinearOperator& A) = 0;
  /// Numeric set-up again after A's values changed on the same pattern; called by update() only
  /// after a successful setup() (system() is the operator to read).
  virtual void update_impl() = 0;
  /// Default: a preconditioner's one correction x += M (b - A x), reported as completed with its
  /// true residual relative to ||b - A x0||; or, when direct_check() is set, a direct solve checked
  /// (and refined) as DirectSolveParams says.
  virtual SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const;
  /// A direct solver returns its check of solve()'s answer; a preconditioner nullptr (the default).
  virtual const DirectSolveParams* direct_check() const { return nullptr; }

 private:
  mutable std::recursive_mutex lock_;
  std::unique_ptr<Csr> owned_;  // the copy made by setup(const CsrView&)
  const LinearOperator* A_ = nullptr;
  index_t n_ = 0;
};

/// A's diagonal: from Csr, Bcsr, BinBcsr or a DiagonalBlocksSource (a matrix-free operator).
/// Throws InputError naming `who` for other operators.
Vector diagonal_of(const LinearOperator& A, const std::string& who);
/// A's 3x3 diagonal blocks, 9 doubles each, row-major: from Bcsr, BinBcsr, a Csr with a size
/// divisible by 3 or a DiagonalBlocksSource. Throws InputError naming `who` otherwise.
std::vector<double> diagonal_blocks_of(const LinearOperator& A, const std::string& who);
/// A as a 3x3-block matrix; throws InputError naming `who` when A is not a Bcsr.
const Bcsr& as_bcsr(const LinearOperator& A, const std::string& who);

/// A scalar CSR copy of a Csr or Bcsr whose pattern is built once (setup) and whose values are
/// refreshed in place (refresh): what the adapters of scalar libraries (CHOLMOD, hypre) read. A Csr
/// is used directly, without a copy.
class ScalarMatrix {
 public:
  /// Takes a Csr as is or copies a Bcsr to scalar CSR (pattern and values); A must outlive this
  /// object. Throws InputError naming `who` for any other operator (BinBcsr, matrix-free).
  void setup(const LinearOperator& A, const std::string& who);
  /// Copies the Bcsr's current values into the scalar copy (same pattern); nothing to do for a Csr.
  void refresh();
  /// The scalar matrix: the Csr itself or the copy. Throws Error before setup().
  const Csr& csr() const;
  /// The block matrix the scalar copy was made from (nullptr for a CSR operator).
  const Bcsr* block() const { return block_; }

 private:
  const Csr* direct_ = nullptr;
  const Bcsr* block_ = nullptr;
  std::unique_ptr<Csr> copy_;
};

}  // namespace pmg
