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

/// BoomerAMG as PMG's lowest-level solver (the seed's "future work" for large meshes), in one of
/// two modes:
///   rel_tol == 0: params.cycles V-cycles from a zero guess: a fixed symmetric linear operator,
///                 so the PMG cycle stays symmetric and can precondition CG (MGPCG);
///   rel_tol  > 0: CG preconditioned by those V-cycles, to ||r|| <= rel_tol ||b||: a sharper but
///                 iteration-dependent (nonlinear) solve, for stationary PMG only. One AMG V-cycle
///                 contracts the long bending modes of a slender body slowly, and stationary PMG
///                 inherits that rate; CG on top removes it.
class BoomerAMGCoarseSolver final : public CoarseSolver {
 public:
  explicit BoomerAMGCoarseSolver(const Bcsr& A, const BoomerAMGParams& params = {},
                                 double rel_tol = 0.0);
  index_t rows() const override { return A_.rows(); }
  index_t cols() const override { return A_.cols(); }
  void update() override { amg_.setup(A_.to_csr()); }
  bool is_linear() const override { return rel_tol_ == 0.0; }

 private:
  void apply_impl(const Vector& b, Vector& x) const override;
  const Bcsr& A_;
  BoomerAMG amg_;
  double rel_tol_;
};

/// What solves a cycle's lowest level.
enum class LowestLevel {
  cholmod,        ///< sparse Cholesky, refactorised on update(): exact; cost grows like n^1.5 in 3-D
  boomeramg,      ///< BoomerAMG V-cycle(s) (params.cycles): inexact, symmetric (MGPCG can use it)
  boomeramg_pcg,  ///< CG preconditioned by BoomerAMG to a relative tolerance (stationary PMG only)
};

/// The lowest-level solver for A (kept by reference: A must outlive it). rel_tol: boomeramg_pcg's
/// tolerance (> 0), ignored otherwise.
std::unique_ptr<CoarseSolver> make_lowest_level(const Bcsr& A, LowestLevel kind,
                                                const BoomerAMGParams& params = {},
                                                double rel_tol = 0.1);

/// Rank and number of ranks of MPI_COMM_WORLD (initialising MPI if needed).
int mpi_rank();
int mpi_size();

}  // namespace pmg::mg
