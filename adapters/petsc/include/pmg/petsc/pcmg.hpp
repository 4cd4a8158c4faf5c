// pmg/petsc/pcmg.hpp — a p-multigrid preconditioned CG across MPI ranks, on PETSc: KSP CG with
// PCMG, every level above the lowest a shell matrix whose product is the caller's matrix-free
// operator on the rank's own elements, the lowest level an assembled MPIAIJ matrix (block size 3,
// rigid-body near-null space) solved by MUMPS, GAMG or BoomerAMG (PCHYPRE), the transfers MPIAIJ.
// It is the PETSc side of pmg::distributed, which knows meshes and partitions; this file knows
// neither, only what one rank holds of each level (RankLevel).
//
// Numbering. Level l has nodes with 3 unknowns each, interleaved. Each rank owns a contiguous
// range [first, first + owned) of the level's global node numbers and sees `global.size()` local
// nodes (its owned nodes and the ghosts its elements touch) in any order; `global[i]` is the global
// number of local node i. Vectors given to and returned by this class hold the owned unknowns in
// global order (3 per node).
//
// A shell product y = A x: x's local nodes gathered from their owners (a PETSc scatter), the
// rank's element sum applied on them, the result added back to the owners (the reverse scatter):
// A = Σ_ranks Gᵀ A_rank G, the same sum of element contributions as the serial operator. The
// (3x3 block) diagonal comes the same way from the operators' diagonal blocks: the smoothers are
// PETSc's Chebyshev (first kind, PETSc's estimate of the largest eigenvalue by 10 CG steps,
// interval [0.1, 1.1] λmax) on point-block Jacobi, D⁻¹ applied by pmgkit's threaded kernel (a
// PCSHELL: PETSc's PCPBJACOBI runs on one thread).
//
// Every call is collective over the communicator given at construction; PETSc options beyond the
// keys (`-mg_levels_ksp_max_it 4`, `-log_view` is the process's own) go into PETSc's options
// database under this object's prefix.
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/defaults.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/monitor.hpp"
#include "pmg/sparse/operator.hpp"
#include "pmg/sparse/solver.hpp"

#include <mpi.h>

#include <memory>
#include <string>
#include <vector>

namespace pmg::petsc {

/// What one rank holds of one level (see the file comment for the numbering).
struct RankLevel {
  /// "degree 2": for messages and breakdowns.
  std::string name;
  /// Global number of the rank's first owned node.
  index_t first = 0;
  /// How many nodes the rank owns.
  index_t owned = 0;
  /// Global number of each local node (owned and ghost).
  std::vector<index_t> global;
  /// Levels above the lowest: the sum of the rank's element operators on its local nodes
  /// (3 unknowns per local node). Must outlive the solver.
  const LinearOperator* op = nullptr;
  /// Levels above the lowest: the 3x3 diagonal blocks of op. Must outlive the solver.
  const DiagonalBlocksSource* blocks = nullptr;
  /// The lowest level: the sum of the rank's element matrices on its local nodes. Read at set-up
  /// and at refresh().
  const Bcsr* matrix = nullptr;
  /// The lowest level: x, y, z of each local node (3 per node; the rigid-body modes).
  std::vector<double> coordinates;
  /// Levels above the lowest: the scalar prolongation from the level below, local nodes x the
  /// level below's local nodes; only the rows of owned nodes are read, and each must be complete
  /// (degree elevation: a node's row reads only its entity's closure, held by any element that
  /// holds the node).
  const Csr* prolongation = nullptr;
  /// Components held on their own (symmetry planes, supports): 1 per held local unknown (3 per
  /// local node), nullptr: none. Their rows of the level's operator are identity rows on every
  /// rank that holds the node (so the owner's row is the ranks' count times the identity) and their
  /// entries of every vector zero; the prolongation leaves them out, as rows here and as columns
  /// on the level above. Must outlive the solver.
  const std::vector<char>* constrained = nullptr;
};

/// The options of PMultigridCg.
struct PcmgParams {
  double rel_tol = 1e-8;       ///< converged when ||r|| <= rel_tol ||b|| (||r_0|| where b = 0)
  /// Also converged when ||r|| <= rhs_floor ||b|| (0: off): the rounding floor of a start near the
  /// solution (a warm-started time step), as KrylovParams::rhs_floor.
  double rhs_floor = 0.0;
  int max_iterations = 10000;  ///< iteration limit (a failure)
  int smoothing_steps = 2;     ///< Chebyshev steps per pre- and post-smoothing (dist::DistributedMgpcgParams)
  /// The lowest level's method, by the names mgpcg's `lowest_level` gives them: "mumps"
  /// (Cholesky), "gamg" (one V-cycle, rigid-body near-null space), "boomeramg" (one BoomerAMG
  /// V-cycle through PCHYPRE: PMIS, extended+i interpolation, Chebyshev relaxation; "hypre" is
  /// its alias) or "auto": MUMPS below amg_threshold global unknowns on the lowest level,
  /// BoomerAMG from there. "cholmod" (one process only) is refused with a pointer to "mumps".
  std::string lowest_level = "auto";
  /// "auto" takes BoomerAMG from this many global unknowns on the lowest level.
  long amg_threshold = kAmgAcrossRanksUnknowns;
  /// Further PETSc options, under this solver's prefix, applied after the defaults.
  std::string options;
  /// Accept options PETSc does not read (else setup() throws InputError naming them).
  bool allow_unused_options = false;
};

/// The ghost exchange of one level's numbering (see the file comment): owned unknowns in global
/// order on one side, the rank's local nodes (owned and ghost, 3 unknowns each) on the other. It is
/// the scatter of the shell products, for a caller's own vectors: a state gathered onto the rank's
/// elements, element forces summed into their owners. Every call is collective.
class GhostExchange {
 public:
  /// Over the ranks of comm: the rank owns global nodes [first, first + owned) and sees the
  /// global nodes `global` (its local nodes, in its order). Throws InputError when owned exceeds
  /// the local nodes, Error with PETSc's message when PETSc fails.
  GhostExchange(MPI_Comm comm, index_t first, index_t owned, const std::vector<index_t>& global);
  ~GhostExchange();
  GhostExchange(const GhostExchange&) = delete;
  GhostExchange& operator=(const GhostExchange&) = delete;
  /// local = the owners' values of the rank's local nodes (3 per local node).
  void to_local(const Vector& owned, Vector& local) const;
  /// owned = Σ over the ranks of their local values, each added into its node's owner.
  void add_to_owners(const Vector& local, Vector& owned) const;
  /// Owned unknowns (3 per owned node).
  index_t owned_size() const { return 3 * owned_; }
  /// Local unknowns (3 per local node).
  index_t local_size() const { return 3 * local_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  index_t owned_ = 0, local_ = 0;
};

/// CG + PCMG over the levels of one rank's share of a distributed hierarchy (see the file
/// comment).
class PMultigridCg {
 public:
  /// Nothing set up. Throws InputError for an unknown lowest level.
  PMultigridCg(MPI_Comm comm, PcmgParams params = {});
  ~PMultigridCg();
  PMultigridCg(const PMultigridCg&) = delete;
  PMultigridCg& operator=(const PMultigridCg&) = delete;

  /// Builds the shell operators, the lowest-level matrix, the transfers and the KSP; levels[0] is
  /// the lowest. Collective. Throws Error with PETSc's message when PETSc fails; a failure on any
  /// rank is thrown on every rank (pmg::mpi::together), PETSc options left unused included.
  void setup(std::vector<RankLevel> levels);
  /// New values of the same operators (a time step's rotations and weights): the diagonals and the
  /// lowest-level matrix re-read, the smoothers' bounds and the lowest-level solver renewed.
  void refresh();
  /// Solves A x = b on the finest level (owned unknowns; x the initial guess). Collective; the
  /// result is the same on every rank. A monitor (any rank's) records ||r_i|| / ||r_0||.
  SolveResult solve(const Vector& b, Vector& x, SolveMonitor* monitor = nullptr) const;
  /// y = A_level x (owned unknowns): the shell product, or the assembled lowest-level matrix.
  void multiply(int level, const Vector& x, Vector& y) const;
  /// y = P_level x from level-1 to level (owned unknowns).
  void prolong(int level, const Vector& x, Vector& y) const;
  /// Number of levels.
  int num_levels() const;
  /// Global unknowns of a level.
  long global_size(int level) const;
  /// The lowest level's method after "auto" is resolved ("mumps", "gamg", "boomeramg").
  const std::string& lowest_level() const { return lowest_; }
  /// Levels, sizes, smoother and lowest level in words, after set-up.
  std::string describe() const;
  /// Seconds of the last set-up by stage (shell levels, lowest-level assembly, transfers, KSP
  /// set-up: the smoothers' estimates and the lowest level's factorisation or hierarchy).
  TimingBreakdown setup_timings() const;
  /// The parameters given at construction.
  const PcmgParams& params() const { return params_; }

 private:
  void set_up(std::vector<RankLevel> levels);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  PcmgParams params_;
  std::string lowest_;
};

}  // namespace pmg::petsc
