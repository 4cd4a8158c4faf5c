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
// The public methods check their preconditions and call private virtuals (Ginkgo's LinOp
// pattern), so an implementation never re-checks sizes. Adding a solver is one class deriving
// from Solver plus one registration in the factory (pmg/multigrid/factory.hpp).
#pragma once

#include "pmg/sparse/monitor.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/operator.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg {

class Bcsr;

class Solver : public LinearOperator {
 public:
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

  bool is_set_up() const { return A_ != nullptr; }
  /// The operator of the last setup().
  const LinearOperator& system() const;
  index_t rows() const override { return n_; }
  index_t cols() const override { return rows(); }

  /// apply() is a fixed linear map of b (false for a Krylov solve to a tolerance).
  virtual bool is_linear() const { return true; }
  /// apply() is a symmetric map, so that it can precondition CG.
  virtual bool is_symmetric() const { return true; }
  /// The solver reads the lower level matrices of a hierarchy besides A (geometric multigrid): a
  /// simulation then assembles its lower levels too. (A Galerkin cycle forms its own from A.)
  virtual bool uses_levels() const { return false; }
  /// The solver applies the hierarchy's matrix-free operators above the lowest level (a
  /// multigrid cycle with operator=matrix-free): a simulation then updates those operators instead
  /// of assembling their matrices, and sets the solver up on the finest matrix-free operator.
  virtual bool uses_matrix_free() const { return false; }
  /// What set-up chose and found, for reports (settings, hierarchy, ordering, factor size); empty
  /// when there is nothing beyond the name. A Krylov method reports its preconditioner's.
  virtual std::string describe() const { return ""; }

 protected:
  virtual void setup_impl(const LinearOperator& A) = 0;
  virtual void update_impl() = 0;
  /// Default: x += M (b - A x), reported with its true residual relative to ||b - A x0||.
  virtual SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const;

 private:
  const LinearOperator* A_ = nullptr;
  index_t n_ = 0;
};

/// A's diagonal: from Csr, Bcsr or BinBcsr. Throws InputError naming `who` for other operators.
Vector diagonal_of(const LinearOperator& A, const std::string& who);
/// A's 3x3 diagonal blocks, 9 doubles each, row-major: from Bcsr, BinBcsr or a Csr with a size
/// divisible by 3. Throws InputError naming `who` otherwise.
std::vector<double> diagonal_blocks_of(const LinearOperator& A, const std::string& who);
/// A as a 3x3-block matrix; throws InputError naming `who` when A is not a Bcsr.
const Bcsr& as_bcsr(const LinearOperator& A, const std::string& who);

/// A scalar CSR copy of a Csr or Bcsr whose pattern is built once (setup) and whose values are
/// refreshed in place (refresh): what the adapters of scalar libraries (CHOLMOD, hypre) read. A Csr
/// is used directly, without a copy.
class ScalarMatrix {
 public:
  void setup(const LinearOperator& A, const std::string& who);
  void refresh();
  const Csr& csr() const;
  /// The block matrix the scalar copy was made from (nullptr for a CSR operator).
  const Bcsr* block() const { return block_; }

 private:
  const Csr* direct_ = nullptr;
  const Bcsr* block_ = nullptr;
  std::unique_ptr<Csr> copy_;
};

}  // namespace pmg
