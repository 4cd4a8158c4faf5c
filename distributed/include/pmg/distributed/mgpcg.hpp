// pmg/distributed/mgpcg.hpp — the factory method petsc-mgpcg: pmgkit's p-multigrid preconditioned
// CG across the MPI ranks of a job, on PETSc (KSP CG + PCMG; pmg/petsc/pcmg.hpp), set up from an
// FEM scene's degree hierarchy (pmg/distributed/rank_hierarchy.hpp). Under `mpirun -np N pmg
// compare ...` every rank builds the same scene, the solver partitions it and each rank solves its
// part; the solution comes back whole on every rank, so the tools check and report it as any
// other solver's (rank 0 prints). With one rank it is the same solver on one process.
//
// Its vectors at the Solver interface are the serial ones (every rank holds all of b and gets all
// of x): the seam to the single-process tools. A code that keeps its own distributed vectors uses
// RankHierarchy and pmg::petsc::PMultigridCg directly.
#pragma once

#include "pmg/distributed/rank_hierarchy.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>

namespace pmg::petsc {
class PMultigridCg;
struct PcmgParams;
}

namespace pmg::dist {

/// The options of petsc-mgpcg (solver keys: see visit()).
struct DistributedMgpcgParams {
  double tol = 1e-8;                  ///< converged when ||r|| <= tol ||b|| (||r_0|| where b = 0)
  int max_iterations = 10000;         ///< CG iteration limit (a failure)
  double rhs_floor = 0.0;             ///< also converged when ||r|| <= rhs_floor ||b|| (0: off)
  bool throw_on_failure = true;       ///< a failed solve throws SolveError
  /// Chebyshev steps per pre- and post-smoothing: 2 solved the quadratic and cubic cubes of
  /// docs/distributed.md in 0.74-0.85x the time of 3 (a few more iterations, fewer products);
  /// 1 took fewer seconds still on the cubes but stalled above 1e-8 on a nearly incompressible bar.
  int smoothing_steps = 2;
  std::string lowest_level = "auto";  ///< auto, mumps, gamg, boomeramg (alias hypre) (pmg::petsc::PcmgParams)
  std::string options;                ///< further PETSc options, under the solver's prefix
  /// Accept PETSc options nobody reads (not a key: the factory sets it from unused_keys).
  bool allow_unused_options = false;
  /// The keys tol, max_iterations, rhs_floor, throw_on_failure, smoothing_steps, lowest_level,
  /// options.
  void visit(ParamVisitor& v);
};

/// The PETSc solver's options from petsc-mgpcg's (the keys map one to one).
petsc::PcmgParams to_pcmg(const DistributedMgpcgParams& params);

/// petsc-mgpcg as a Solver over the serial vectors of a DegreeHierarchy (see the file comment).
class DistributedMgpcg final : public Solver {
 public:
  /// Over the ranks of comm; `serial` (the scene's hierarchy, on every rank) must outlive it.
  /// setup(), update() and solve() are collective and check first that every rank holds the same
  /// keys, model (mesh, material, fixed nodes), right-hand side and start (pmg::mpi::check_agreement:
  /// an InputError on every rank names the first difference); a failure on any rank is thrown on
  /// every rank (pmg::mpi::together).
  DistributedMgpcg(const fem::DegreeHierarchy& serial, DistributedMgpcgParams params = {},
                   MPI_Comm comm = MPI_COMM_WORLD);
  ~DistributedMgpcg() override;

  std::string name() const override { return "petsc-mgpcg"; }
  /// The finest level's matrix-free operator: the tools' residual checks multiply with it.
  SolverNeeds needs() const override { return {false, true}; }
  bool is_linear() const override { return false; }
  bool is_symmetric() const override { return false; }
  std::string describe() const override;
  TimingBreakdown setup_timings() const override;
  /// Per level (finest first) and rank: (ghost nodes, owned nodes), gathered at set-up.
  const std::vector<std::vector<std::pair<long, long>>>& ghosts_per_rank() const { return ghosts_; }
  /// The rank's share (after set-up).
  const RankHierarchy& ranks() const { return *ranks_; }
  /// The PETSc solver (after set-up).
  const petsc::PMultigridCg& petsc_solver() const { return *solver_; }

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;
  void apply_impl(const Vector& b, Vector& x) const override;
  void set_up_ranks();

  const fem::DegreeHierarchy* serial_;
  DistributedMgpcgParams params_;
  MPI_Comm comm_;
  std::unique_ptr<RankHierarchy> ranks_;
  std::unique_ptr<petsc::PMultigridCg> solver_;
  std::vector<std::pair<std::string, double>> partition_seconds_;
  /// Per level (finest first), per rank: ghost and owned nodes (gathered at set-up).
  std::vector<std::vector<std::pair<long, long>>> ghosts_;
};

/// Registers petsc-mgpcg (idempotent).
void register_solvers();

}  // namespace pmg::dist
