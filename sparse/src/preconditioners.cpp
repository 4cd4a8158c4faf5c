#include "pmg/sparse/preconditioners.hpp"

#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <algorithm>
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

std::vector<double> invert_diagonal_blocks(std::vector<double> blocks, const std::string& who) {
  if (blocks.size() % 9 != 0) throw InputError(who + ": diagonal block array is not a multiple of 9");
  const std::ptrdiff_t nb = static_cast<std::ptrdiff_t>(blocks.size() / 9);
  std::ptrdiff_t first_bad = nb;  // the lowest block that is not SPD, whatever the thread count
#pragma omp parallel for schedule(static) reduction(min : first_bad)
  for (std::ptrdiff_t I = 0; I < nb; ++I) {
    Eigen::Map<Block3> D(blocks.data() + 9 * I);
    const Eigen::LLT<Eigen::Matrix3d> llt(D);
    if (!D.allFinite() || llt.info() != Eigen::Success) {
      first_bad = std::min(first_bad, I);
      continue;
    }
    D = llt.solve(Eigen::Matrix3d::Identity());  // in place: D was read into the factor
  }
  if (first_bad < nb)
    throw InputError(who + ": diagonal block " + std::to_string(first_bad) + " is not symmetric positive definite");
  return blocks;
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
