// pmg/multigrid/cycle.hpp — multigrid cycles over any number of levels: PMG, and MGPCG's
// preconditioner.
//
// Levels are numbered from the coarsest (0) to the finest (L-1) and come from a LevelProvider
// (pmg/multigrid/levels.hpp). Level l >= 1 has a matrix A_l, a smoother and a transfer from level
// l-1; level 0 has a matrix and a lowest-level solver (any Solver: CHOLMOD by default, BoomerAMG,
// a CG). One cycle improves x for A_{L-1} x = b:
//
//   cycle(l, b, x):  l == 0: x = S_0 b                      (the lowest-level solver)
//                    else:   pre-smooth; r_c = R (b - A_l x); x_c = 0; cycle(l-1, r_c, x_c) γ times
//                            (γ = 1: V, γ = 2: W); x += P x_c; post-smooth
//
// With R = Pᵀ, adjoint pre/post smoothing and a symmetric linear lowest-level solver the cycle is
// a symmetric operator, so it can precondition CG: MGPCG is Cg with a MultigridCycle as its
// preconditioner (the factory's "mgpcg"). As a Solver:
//   setup(A)   A is the finest level's operator (its size is checked against the provider's);
//              builds the transfers, the Galerkin products (if asked for), sets up each level's
//              smoother and the lowest-level solver, and allocates every work vector;
//   update()   the provider's matrices have new values: Galerkin products, smoothers and the
//              lowest-level solver refresh their numbers (patterns and colourings are kept);
//   apply      `cycles` cycles from x = 0 (the preconditioner);
//   solve      stationary multigrid x <- x + C (b - A x), one cycle per iteration, with the Krylov
//              solvers' stopping rules (relative residual, divergence, NaN, stagnation).
#pragma once

#include "pmg/multigrid/levels.hpp"
#include "pmg/multigrid/smoothers.hpp"
#include "pmg/multigrid/transfer.hpp"
#include "pmg/sparse/krylov.hpp"

#include <functional>
#include <memory>
#include <vector>

namespace pmg::mg {

class Chebyshev;

/// Where the matrices of the levels below the finest come from.
enum class CoarseOperator {
  geometric,  ///< the provider's own level matrices (re-discretised, same rotations on every level)
  galerkin,   ///< R A P from the finest matrix down (two sparse products per level)
};

/// Parameters of MultigridCycle (checked by its constructor and setup()).
struct MultigridParams {
  int gamma = 1;   ///< 1: V-cycle, 2: W-cycle
  int cycles = 1;  ///< cycles per apply() (as a preconditioner; the seed's MGPCG uses 2)
  /// The lower levels' matrices: the provider's own or Galerkin products R A P.
  CoarseOperator coarse_operator = CoarseOperator::geometric;
  /// The provider's interpolating restriction instead of Pᵀ (the cycle is then not symmetric).
  bool interpolating_restriction = false;
  /// Levels above the lowest smoothed and their residuals formed with the provider's matrix-free
  /// operators (LevelProvider::matrix_free_operator), not its matrices; geometric coarse
  /// operators only.
  bool matrix_free = false;
  /// The levels above the lowest in float inside the cycle: their matrix-free operators
  /// (SinglePrecisionSource), Chebyshev smoothing and transfers; the lowest level, and the outer
  /// iteration's residuals and solution, in double. Matrix-free levels smoothed by Chebyshev only,
  /// without components constrained on their own.
  bool single_precision = false;
  /// With single_precision: levels that cannot run in float (held components, operators without a
  /// float product, smoothers other than Chebyshev) run in double instead of being refused.
  bool single_where_possible = false;
  /// Why the smoothers are what they are, where a factory chose them from the levels (printed by
  /// describe(); empty: nothing to add).
  std::string smoother_choice;
  /// solve(): the stationary iteration's stopping rule.
  KrylovParams iteration;
};

/// Time spent in each part of the cycles applied so far (seconds), for cost breakdowns.
struct CycleTimings {
  std::vector<double> smoothing;  ///< per level
  /// \var residual
  /// Forming the residuals b - A x on the levels above the lowest.

  /// Restrictions and prolongations.
  double transfer = 0.0, residual = 0.0, lowest_level = 0.0;  ///< the lowest-level solves
  /// Number of cycles the times cover.
  long cycles = 0;
};

/// Builds the smoother of level l (1 <= l <= L-1); called at construction.
using SmootherFactory = std::function<std::unique_ptr<Smoother>(int level)>;

/// A V- or W-cycle over a LevelProvider's levels as a Solver (see the file comment): PMG's
/// stationary iteration through solve(), MGPCG's preconditioner through apply().
class MultigridCycle final : public Solver {
 public:
  /// The provider must outlive the cycle; its matrices stay where they are. Takes ownership of
  /// the lowest-level solver and calls `smoothers` once per level above the lowest. Throws
  /// InputError for no levels, gamma other than 1 or 2, cycles below 1, or a null solver or
  /// smoother.
  MultigridCycle(const LevelProvider& levels, const MultigridParams& params,
                 const SmootherFactory& smoothers, std::unique_ptr<Solver> lowest_level);
  /// The same on levels the cycle keeps alive (a LevelsFrom view the factory built).
  MultigridCycle(std::shared_ptr<const LevelProvider> levels, const MultigridParams& params,
                 const SmootherFactory& smoothers, std::unique_ptr<Solver> lowest_level);

  std::string name() const override;
  bool is_linear() const override;
  /// R = Pᵀ on every level, the smoothers linear adjoint pairs (is_symmetric) and the lowest-level
  /// solver linear and symmetric.
  bool is_symmetric() const override;
  /// Geometric lower levels are the provider's matrices (Galerkin ones are formed here from A);
  /// the matrix-free route applies the provider's operators above the lowest level. On a
  /// LevelsFrom view, lowest_level is the base's level behind the view's level 0.
  SolverNeeds needs() const override {
    return {params_.coarse_operator != CoarseOperator::galerkin, params_.matrix_free, provider_lowest_};
  }
  /// Per cycle: smoothing on each level above the lowest (finest first), residuals, transfers and
  /// the lowest-level solve.
  TimingBreakdown timings() const override;
  /// The last setup() or update(): transfers (and Galerkin products), each level's smoother
  /// (diagonal blocks, eigenvalue estimates), the lowest-level solver.
  TimingBreakdown setup_timings() const override { return setup_timings_; }
  void reset_timings() const override;

  /// Number of levels L (the provider's).
  int num_levels() const { return levels_.num_levels(); }
  /// The level provider the cycle was built on.
  const LevelProvider& levels() const { return levels_; }
  /// The parameters.
  const MultigridParams& params() const { return params_; }
  /// The parameters, to change between solves: cycles, gamma and the iteration's stopping rule
  /// take effect at once; coarse_operator, matrix_free, interpolating_restriction and
  /// single_precision only at the next setup().
  MultigridParams& params() { return params_; }
  /// The matrix a level's smoother and residual use (a Galerkin product below the finest level
  /// when asked for).
  const Bcsr& level_matrix(int level) const;
  /// The operator a level's smoother and residual apply: the provider's matrix-free operator
  /// (matrix_free, levels >= 1) or level_matrix().
  const LinearOperator& level_operator(int level) const;
  /// The transfer between level `level` - 1 and `level` (1 <= level <= L-1; built by setup():
  /// std::out_of_range before it).
  const BlockTransfer& transfer(int level) const { return transfers_.at(level - 1); }
  /// The smoother of level `level` (1 <= level <= L-1; std::out_of_range otherwise).
  const Smoother& smoother(int level) const { return *smoothers_.at(level - 1); }
  /// The levels (finest first, with their unknowns), the coarse operators, the smoothers, the
  /// lowest level's solver and what it found, the cycles per application and any components
  /// constrained on their own: what set-up chose, in words.
  std::string describe() const override;
  /// The lowest-level solver (level 0).
  const Solver& lowest_level() const { return *lowest_; }

  /// One cycle improving x for A x = b in place (x is the initial guess).
  void cycle(const Vector& b, Vector& x) const { cycle(num_levels() - 1, b, x); }

  /// The raw seconds behind timings().
  const CycleTimings& cycle_timings() const { return timings_; }
  /// Galerkin coarse operators only: recomputes the products R A P from the finest level down into
  /// their kept patterns (update() does this, then refreshes smoothers and the lowest level).
  void refresh_galerkin();

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  /// update() may refresh the lowest level on the calling thread beside the smoothers on a
  /// second one: the lowest level's update is serial (Solver::update_is_serial), every smoother is
  /// a D⁻¹ Chebyshev on a pmgkit operator (no user code on the second thread), two threads are free.
  bool overlap_lowest_update() const;
  void apply_impl(const Vector& r, Vector& z) const override;
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;
  /// x_is_zero: x holds zeros (the smoother may start from that: pre_smooth_from_zero).
  void cycle(int level, const Vector& b, Vector& x, bool x_is_zero = false) const;

  /// A level above the lowest in float (precision=single): its operator, its Chebyshev smoother's
  /// D⁻¹ and the transfer from the level below, rounded to float, and work vectors.
  struct SingleLevel {
    const SinglePrecisionSource* op = nullptr;
    const Chebyshev* smoother = nullptr;
    std::vector<float> p_values, r_values;
    const float* inv = nullptr;  ///< float D⁻¹: the smoother's own (inverse_diagonal_single)
    mutable Eigen::VectorXf r, rc, xc, d;
  };
  std::vector<SingleLevel> single_;  ///< [l]: level l >= 1 (precision=single only)
  mutable Eigen::VectorXf single_r_, single_z_;
  mutable Vector lowest_b_, lowest_x_;
  /// Builds single_ (set-up) or refreshes its inverse diagonals (update). At set-up, levels that
  /// cannot run in float are an InputError, or (single_where_possible) leave single_ empty.
  void prepare_single(bool setup);
  /// Level l's float D⁻¹ from its smoother's.
  void refresh_single(int l);
  /// Why the levels' scale does not fit float ("" if it does).
  std::string float_range_obstacle() const;
  /// cycle() in float on levels >= 1 (the lowest level in double).
  void cycle_single(int level, const Eigen::VectorXf& b, Eigen::VectorXf& x, bool x_is_zero) const;
  /// The level's Chebyshev smoothing in float (Chebyshev::smooth's recurrence).
  void smooth_single(int level, const Eigen::VectorXf& b, Eigen::VectorXf& x, bool x_is_zero) const;

  std::shared_ptr<const LevelProvider> owned_levels_;  ///< the levels, where the cycle keeps them alive
  const LevelProvider& levels_;
  /// The level of the provider behind level 0 (a LevelsFrom view's skip; 0 otherwise): needs().
  int provider_lowest_ = 0;
  MultigridParams params_;
  std::vector<std::unique_ptr<Smoother>> smoothers_;  ///< [l-1]: level l
  std::unique_ptr<Solver> lowest_;
  std::vector<BlockTransfer> transfers_;              ///< [l-1]: level l-1 -> l
  std::vector<GalerkinProduct> galerkin_;             ///< [l]: level l < L-1 (Galerkin only)
  struct Work {
    Vector r, rc, xc;  ///< level l's residual, and the coarse right-hand side and correction
  };
  mutable std::vector<Work> work_;  ///< [l]: level l >= 1
  mutable Vector solve_r_;
  mutable CycleTimings timings_;
  TimingBreakdown setup_timings_;
  /// Runs `stage` and adds its seconds to setup_timings_ under `name`.
  void timed_stage(const std::string& name, const std::function<void()>& stage);
  /// Replaces the last set-up stage (the lowest level's) by the lowest level's own stages, if any.
  void itemise_lowest();
};

}  // namespace pmg::mg
