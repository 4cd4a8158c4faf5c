// pmg/multigrid/boomeramg.hpp — hypre's BoomerAMG, the algebraic-multigrid baseline, as a
// Preconditioner (one V-cycle per apply, for PCG) and as a lowest-level solver for PMG.
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

#include "pmg/multigrid/cycle.hpp"

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

class BoomerAMG final : public Preconditioner {
 public:
  explicit BoomerAMG(const Csr& A, const BoomerAMGParams& params = {});
  ~BoomerAMG() override;
  BoomerAMG(const BoomerAMG&) = delete;
  BoomerAMG& operator=(const BoomerAMG&) = delete;

  /// New values (or a new matrix): BoomerAMG's set-up depends on the values, so it is redone.
  void setup(const Csr& A);

  index_t rows() const override { return n_; }
  index_t cols() const override { return n_; }
  std::string name() const override { return "boomeramg"; }

 private:
  void apply_impl(const Vector& r, Vector& z) const override;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  index_t n_ = 0;
};

/// BoomerAMG as PMG's lowest-level solver (the seed's "future work" for large meshes).
class BoomerAMGCoarseSolver final : public CoarseSolver {
 public:
  explicit BoomerAMGCoarseSolver(const Bcsr& A, const BoomerAMGParams& params = {});
  index_t rows() const override { return A_.rows(); }
  index_t cols() const override { return A_.cols(); }
  void update() override { amg_.setup(A_.to_csr()); }

 private:
  void apply_impl(const Vector& b, Vector& x) const override { amg_.apply(b, x); }
  const Bcsr& A_;
  BoomerAMG amg_;
};

/// Rank and number of ranks of MPI_COMM_WORLD (initialising MPI if needed).
int mpi_rank();
int mpi_size();

}  // namespace pmg::mg
