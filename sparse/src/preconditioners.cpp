#include "pmg/sparse/preconditioners.hpp"

#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <cmath>
#include <string>

namespace pmg {

void JacobiPreconditioner::setup_impl(const LinearOperator& A) {
  const Vector diagonal = diagonal_of(A, "Jacobi");
  inv_diag_.resize(diagonal.size());
  for (Eigen::Index i = 0; i < diagonal.size(); ++i) {
    const double d = diagonal[i];
    if (!(d > 0.0) || !std::isfinite(d))
      throw InputError("Jacobi: diagonal entry " + std::to_string(i) + " is " + std::to_string(d) +
                       "; an SPD matrix has a positive diagonal");
    inv_diag_[i] = 1.0 / d;
  }
}

void JacobiPreconditioner::apply_impl(const Vector& r, Vector& z) const {
  const Eigen::Index n = r.size();
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) z[i] = inv_diag_[i] * r[i];
}

std::vector<double> invert_diagonal_blocks(const std::vector<double>& diagonal_blocks,
                                           const std::string& who) {
  if (diagonal_blocks.size() % 9 != 0)
    throw InputError(who + ": diagonal block array is not a multiple of 9");
  std::vector<double> inv(diagonal_blocks.size());
  const size_t nb = diagonal_blocks.size() / 9;
  for (size_t I = 0; I < nb; ++I) {
    const Eigen::Map<const Block3> D(diagonal_blocks.data() + 9 * I);
    Eigen::LLT<Eigen::Matrix3d> llt(D);
    if (!D.allFinite() || llt.info() != Eigen::Success)
      throw InputError(who + ": diagonal block " + std::to_string(I) +
                       " is not symmetric positive definite");
    Eigen::Map<Block3>(inv.data() + 9 * I) = llt.solve(Eigen::Matrix3d::Identity());
  }
  return inv;
}

void BlockJacobiPreconditioner::setup_impl(const LinearOperator& A) {
  check_interleaved(A, "block Jacobi");
  inv_blocks_ = invert_diagonal_blocks(diagonal_blocks_of(A, "block Jacobi"), "block Jacobi");
}

void BlockJacobiPreconditioner::update_impl() {
  inv_blocks_ = invert_diagonal_blocks(diagonal_blocks_of(system(), "block Jacobi"), "block Jacobi");
}

void BlockJacobiPreconditioner::apply_impl(const Vector& r, Vector& z) const {
  ops::block_diagonal_apply(inv_blocks_, r, z);
}

}  // namespace pmg
