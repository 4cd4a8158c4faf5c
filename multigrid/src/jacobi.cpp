#include "pmg/multigrid/smoothers.hpp"

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/preconditioners.hpp"
#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <cmath>

namespace pmg::mg {

BlockJacobi::BlockJacobi(const JacobiParams& params) : params_(params) {
  if (!(params.omega > 0)) throw InputError("Jacobi: omega must be positive");
  if (params.sweeps < 1)
    throw InputError("Jacobi: sweeps must be >= 1 (a smoother that does nothing leaves the cycle without smoothing)");
}

namespace {
/// The l1 blocks: A_II plus, on the diagonal, Σ_{J≠I} Σ_c |(A_IJ)_rc| for each scalar row r.
std::vector<double> l1_diagonal_blocks(const LinearOperator& A) {
  const Bcsr* B = A.bcsr_matrix();
  if (!B) throw InputError("l1-jacobi: needs the matrix as BCSR (3x3 blocks)");
  const BlockPattern& p = B->pattern();
  std::vector<double> blocks(9 * static_cast<size_t>(p.rows), 0.0);
#pragma omp parallel for schedule(static)
  for (index_t I = 0; I < p.rows; ++I) {
    double* d = blocks.data() + 9 * static_cast<size_t>(I);
    for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k) {
      const auto a = B->block(k);
      for (int r = 0; r < 3; ++r) {
        if (p.col_idx[k] == I)
          for (int c = 0; c < 3; ++c) d[3 * r + c] += a(r, c);
        else
          d[4 * r] += std::abs(a(r, 0)) + std::abs(a(r, 1)) + std::abs(a(r, 2));
      }
    }
  }
  return blocks;
}
}  // namespace

void BlockJacobi::setup_impl(const LinearOperator& A) {
  check_interleaved(A, name());
  r_.resize(A.rows());
  invert_diagonal(A);
}

void BlockJacobi::update_impl() { invert_diagonal(system()); }

void BlockJacobi::invert_diagonal(const LinearOperator& A) {
  inv_diag_ = params_.l1 ? invert_diagonal_blocks(l1_diagonal_blocks(A), "l1-jacobi") : inverse_diagonal_blocks(A);
}

void BlockJacobi::smooth(const Vector& b, Vector& x) const {
  const LinearOperator& A = system();
  for (int s = 0; s < params_.sweeps; ++s) {
    A.residual(b, x, r_);
    ops::block_diagonal_axpy(params_.omega, inv_diag_, r_, x);
  }
}

Richardson::Richardson(std::unique_ptr<Solver> M, const RichardsonParams& params)
    : M_(std::move(M)), params_(params) {
  if (!M_) throw InputError("Richardson: no preconditioner");
  if (params.iterations < 1) throw InputError("Richardson: iterations must be >= 1");
  if (!(params.omega > 0)) throw InputError("Richardson: omega must be positive");
}

void Richardson::setup_impl(const LinearOperator& A) {
  M_->setup(A);
  r_.resize(A.rows()), z_.resize(A.rows());
}

void Richardson::smooth(const Vector& b, Vector& x) const {
  const LinearOperator& A = system();
  for (int k = 0; k < params_.iterations; ++k) {
    A.residual(b, x, r_);
    M_->apply(r_, z_);
    x += params_.omega * z_;
  }
}

}  // namespace pmg::mg
