// pmg/multigrid/cycle.hpp — multigrid cycles over any number of levels, PMG and MGPCG.
//
// Levels are numbered from the coarsest (0) to the finest (L-1). Level l >= 1 has a matrix A_l, a
// smoother, and a transfer from level l-1; level 0 has a matrix and a lowest-level solver (CHOLMOD
// by default). One cycle, applied to r with x = 0, approximates A_{L-1}^{-1} r:
//
//   cycle(l, b, x):  l == 0: x = A_0^{-1} b
//                    else:   pre-smooth; r_c = R (b - A_l x); x_c = 0; cycle(l-1, r_c, x_c) γ times
//                            (γ = 1: V, γ = 2: W); x += P x_c; post-smooth
//
// With R = Pᵀ and adjoint pre/post smoothing the cycle is a symmetric operator, so it can
// precondition CG (MGPCG). The cycle keeps references to the matrices: after their values change
// (new rotations), call update() to refresh the smoothers and refactorise the lowest level.
#pragma once

#include "pmg/multigrid/smoothers.hpp"
#include "pmg/multigrid/transfer.hpp"
#include "pmg/sparse/cholmod_solver.hpp"
#include "pmg/sparse/krylov.hpp"

#include <memory>
#include <vector>

namespace pmg::mg {

/// The lowest-level solver of a cycle.
class CoarseSolver : public LinearOperator {
 public:
  /// The matrix values changed (same pattern).
  virtual void update() = 0;
  /// False when the solve depends on its input beyond linearly (an inner Krylov solve to a
  /// tolerance): the cycle is then no fixed symmetric operator and cannot precondition CG.
  virtual bool is_linear() const { return true; }
};

/// Sparse Cholesky of the lowest level: symbolic analysis once, numeric factorisation per update().
class CholmodCoarseSolver final : public CoarseSolver {
 public:
  explicit CholmodCoarseSolver(const Bcsr& A);
  index_t rows() const override { return A_.rows(); }
  index_t cols() const override { return A_.cols(); }
  void update() override;

 private:
  void apply_impl(const Vector& b, Vector& x) const override { chol_.solve(b, x); }
  const Bcsr& A_;
  CholmodSolver chol_;
};

struct CycleParams {
  int gamma = 1;  ///< 1: V-cycle, 2: W-cycle
};

/// Time spent in each part of the cycles applied so far (seconds), for cost breakdowns.
struct CycleTimings {
  std::vector<double> smoothing;  ///< per level
  double transfer = 0.0, residual = 0.0, coarse = 0.0;
  long cycles = 0;
};

class MultigridCycle final : public Preconditioner {
 public:
  /// matrices[l], l = 0..L-1 (coarsest first); transfers[l-1] maps level l-1 to level l;
  /// smoothers[l-1] belongs to level l.
  MultigridCycle(std::vector<const Bcsr*> matrices, std::vector<const BlockTransfer*> transfers,
                 std::vector<std::unique_ptr<Smoother>> smoothers,
                 std::unique_ptr<CoarseSolver> coarse, const CycleParams& params = {});

  index_t rows() const override { return matrices_.back()->rows(); }
  index_t cols() const override { return rows(); }
  std::string name() const override { return params_.gamma == 1 ? "V-cycle" : "W-cycle"; }
  int num_levels() const { return static_cast<int>(matrices_.size()); }
  /// True when R = Pᵀ on every level (the smoothers used here are adjoint pairs) and the
  /// lowest-level solver is a linear operator.
  bool is_symmetric() const;

  /// Refresh smoothers and the lowest-level factorisation after the matrices' values changed.
  void update();
  /// One cycle improving x for A x = b in place (x is the initial guess).
  void cycle(const Vector& b, Vector& x) const { cycle(num_levels() - 1, b, x); }

  const CycleTimings& timings() const { return timings_; }
  void reset_timings() const;

 private:
  void apply_impl(const Vector& r, Vector& z) const override;
  void cycle(int level, const Vector& b, Vector& x) const;

  std::vector<const Bcsr*> matrices_;
  std::vector<const BlockTransfer*> transfers_;
  std::vector<std::unique_ptr<Smoother>> smoothers_;
  std::unique_ptr<CoarseSolver> coarse_;
  CycleParams params_;
  mutable CycleTimings timings_;
};

/// PMG as a solver: x <- x + C (b - A x), one cycle per iteration, with the Krylov solvers'
/// stopping rules (relative residual, divergence, NaN, stagnation) and monitor.
SolveResult multigrid_solve(const LinearOperator& A, const MultigridCycle& C, const Vector& b,
                            Vector& x, const KrylovParams& params = {},
                            SolveMonitor* monitor = nullptr);

/// MGPCG: CG preconditioned by `cycles_per_apply` cycles (the seed uses two). Needs a symmetric
/// cycle; throws InputError otherwise.
SolveResult mgpcg(const LinearOperator& A, const MultigridCycle& C, const Vector& b, Vector& x,
                  const KrylovParams& params = {}, SolveMonitor* monitor = nullptr,
                  int cycles_per_apply = 2);

}  // namespace pmg::mg
