// pmg/multigrid/boomeramg.hpp — hypre's BoomerAMG, the algebraic-multigrid baseline, as a Solver
// (V-cycles per apply, for PCG, or as the lowest-level solver of PMG). The one hypre adapter.
//
// Settings for 3-D elasticity (3 unknowns per node, interleaved), as a careful user would choose:
//   systems AMG with 3 functions and nodal coarsening on the row-sum norm of the 3x3 blocks
//   (SetNumFunctions 3, SetNodal 4, SetNodalDiag 1): the three displacement components of a node
//   are coarsened together, so rigid-body-like modes are not split between grids;
//   strong threshold 0.5 (hypre's advice for 3-D; 0.25 is the 2-D default);
//   HMIS coarsening (10) with extended+i interpolation (6) truncated to 4 entries per row: the
//   standard low-complexity pairing for 3-D;
//   l1-scaled symmetric Gauss–Seidel relaxation (8): symmetric, so the cycle can precondition CG;
//   no aggressive coarsening (it hurts elasticity); one V-cycle per apply, tolerance 0.
// MPI is initialised on first use (one rank by default; under mpirun each rank owns a contiguous
// block of rows, every rank holds the whole matrix and vectors, and results are gathered).
#pragma once

#include "pmg/sparse/config.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>

namespace pmg::mg {

struct BoomerAMGParams {
  int num_functions = 3;
  int nodal = 4;
  double strong_threshold = 0.5;
  int coarsen_type = 10;
  int interp_type = 6;
  int p_max_elements = 4;
  int relax_type = 8;
  int cycles = 1;  ///< V-cycles per apply
};

class BoomerAMG final : public Solver {
 public:
  explicit BoomerAMG(const BoomerAMGParams& params = {});
  /// Sets up on A at once (CSR or BCSR).
  BoomerAMG(const LinearOperator& A, const BoomerAMGParams& params) : BoomerAMG(params) { setup(A); }
  ~BoomerAMG() override;
  BoomerAMG(const BoomerAMG&) = delete;
  BoomerAMG& operator=(const BoomerAMG&) = delete;

  std::string name() const override { return "boomeramg"; }
  const BoomerAMGParams& params() const;

 private:
  /// A: Csr, or Bcsr (its scalar copy's pattern is built once; update() copies values only).
  void setup_impl(const LinearOperator& A) override;
  /// BoomerAMG's set-up depends on the values (coarsening, interpolation), so it is redone.
  void update_impl() override;
  void apply_impl(const Vector& r, Vector& z) const override;
  void build(const Csr& A);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  ScalarMatrix scalar_;
};

/// Rank and number of ranks of MPI_COMM_WORLD (initialising MPI if needed).
int mpi_rank();
int mpi_size();

/// When a solver configuration uses hypre (a method starting "boomeramg" anywhere in it), starts
/// MPI now — its start-up is paid once per process, not per solve, so a caller does this before
/// its clocks — and returns the seconds it took; otherwise returns a negative number.
double start_mpi_for_hypre(const Config& config);

}  // namespace pmg::mg
