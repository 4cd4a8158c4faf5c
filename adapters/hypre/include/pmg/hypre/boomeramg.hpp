// pmg/hypre/boomeramg.hpp — hypre's BoomerAMG, the algebraic-multigrid baseline, as a Solver
// (V-cycles per apply, for PCG, or as the lowest-level solver of PMG). The one hypre adapter.
//
// Every BoomerAMG option that matters for elasticity is a field of BoomerAMGParams and a key of the
// factory (BoomerAMGParams::visit; `pmg solvers`). The defaults are the fastest that
// tools/amg_sweep.py found on the Homer P3 and Bunny P2 systems (docs/performance.md): HMIS
// coarsening with one level of aggressive coarsening (multipass interpolation there), extended+i
// interpolation truncated to 6 entries, strong threshold 0.5, unknown-based systems AMG,
// l1-Gauss-Seidel. Nodal coarsening needed more iterations than unknown-based systems AMG on these
// higher-order matrices, so it is off.
// Rigid-body interpolation vectors (Baker, Kolev & Yang, "Improving algebraic multigrid
// interpolation operators for linear elasticity problems", 2010) are an option: the three
// rotations computed from node coordinates (SolverContext::coordinates), which hypre supports only
// with nodal coarsening.
// MPI is started on first use (pmg/mpi/session.hpp; one rank by default; under mpirun each rank
// owns a contiguous block of rows, every rank holds the whole matrix and vectors, and results are
// gathered).
#pragma once

#include "pmg/sparse/config.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg::hypre {

/// BoomerAMG's options (hypre's numeric codes; see the file comment for the defaults).
struct BoomerAMGParams {
  /// Unknowns per node (systems AMG), interleaved; 0 (the default): 3 where the matrix carries
  /// 3x3 blocks (a Bcsr, or a Csr for which pmg::reads_as_blocks() holds), else 1.
  int num_functions = 0;
  int nodal = 0;                ///< 0: unknown-based; 1-6: nodal coarsening on a norm of the blocks
  int nodal_diag = 1;           ///< nodal: 1 = diagonal of the nodal matrix is minus the row sum
  /// Strength-of-connection threshold, in (0, 1).
  double strong_threshold = 0.5;
  int coarsen_type = 10;        ///< 10 HMIS, 8 PMIS, 6 Falgout, ...
  int interp_type = 6;          ///< 6 extended+i, 0 classical, ...
  int p_max_elements = 6;       ///< interpolation entries per row (0: no limit)
  double trunc_factor = 0.0;    ///< interpolation truncation factor
  int relax_type = 8;           ///< 8 l1-symmetric Gauss-Seidel, 6 hybrid symmetric GS, 16 Chebyshev, ...
  int relax_coarse = 9;         ///< relaxation on the coarsest level (9: Gaussian elimination)
  int relax_order = 0;          ///< 0 natural order, 1 C/F order
  int sweeps = 1;               ///< relaxation sweeps per level, down and up
  int agg_levels = 1;           ///< levels of aggressive coarsening
  int agg_interp_type = 4;      ///< interpolation on aggressive levels (4: multipass)
  int max_levels = 25;          ///< levels at most
  int max_coarse_size = 9;      ///< coarsest level size at most
  int interp_vectors = 0;       ///< 0 none, 3 the rigid-body rotations (needs coordinates, nodal)
  int interp_vec_variant = 2;   ///< 1, 2: GM approaches, 3: LN approach
  int interp_vec_q_max = 0;     ///< entries per row of each vector's interpolation block (0: no limit)
  int smooth_interp_vectors = 0;  ///< 1: smooth the rigid-body vectors on each level before use
  int cycles = 1;               ///< V-cycles per apply
  /// Every field above as a factory key (p_max_elements is `p_max`, interp_vectors none | rigid).
  void visit(ParamVisitor& v);
};

/// The settings as "key=value ..." in the factory's key names.
std::string to_string(const BoomerAMGParams& params);

/// hypre's BoomerAMG as a Solver (see the file comment).
class BoomerAMG final : public Solver {
 public:
  /// Not yet set up. Throws InputError for inconsistent parameters (num_functions or cycles below
  /// 1, strong_threshold outside (0, 1), rigid-body vectors without nodal coarsening or without 3
  /// functions).
  explicit BoomerAMG(const BoomerAMGParams& params = {});
  /// Sets up on A at once (CSR or BCSR).
  BoomerAMG(const LinearOperator& A, const BoomerAMGParams& params) : BoomerAMG(params) { setup(A); }
  ~BoomerAMG() override;
  BoomerAMG(const BoomerAMG&) = delete;
  BoomerAMG& operator=(const BoomerAMG&) = delete;

  std::string name() const override { return "boomeramg"; }
  /// The parameters given at construction.
  const BoomerAMGParams& params() const;
  /// Node coordinates (x, y, z per node of the system, interleaved like the unknowns) for the
  /// rigid-body interpolation vectors; needed before setup() when params.interp_vectors > 0.
  void set_coordinates(std::vector<double> xyz);
  /// The settings, and after set-up the hierarchy: levels, grid and operator complexity.
  std::string describe() const override;
  /// After set-up: number of levels, sum of the level sizes / finest size, and the same for nonzeros.
  int num_levels() const;
  /// After set-up: the sum of the level sizes over the finest size (0 before set-up).
  double grid_complexity() const;
  /// After set-up: the sum of the levels' nonzeros over the finest level's (0 before set-up).
  double operator_complexity() const;

 private:
  /// A: Csr, or Bcsr (read block row by block row: no scalar copy). hypre's matrix is built
  /// directly from A's rows, its exact zeros off the diagonal left out; update() builds it again.
  void setup_impl(const LinearOperator& A) override;
  /// BoomerAMG's set-up depends on the values (coarsening, interpolation), so it is redone.
  void update_impl() override;
  void apply_impl(const Vector& r, Vector& z) const override;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Registers the methods boomeramg and boomeramg-pcg (idempotent; a name the user registered is kept); their
/// start-up hook starts MPI (pmg::start_libraries).
void register_solvers();

}  // namespace pmg::hypre

namespace pmg::mg {
/// The adapter's names before it moved to its folder's namespace (pmgkit 0.2); kept for callers.
using hypre::BoomerAMG;
using hypre::BoomerAMGParams;
}  // namespace pmg::mg
