// pmg/sparse/preconditioners.hpp — diagonal preconditioners: point Jacobi and 3x3 block Jacobi.
// Set-up checks that the (block) diagonal is SPD and names the first row or block that is not.
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/operator.hpp"

#include <vector>

namespace pmg {

/// z = D^{-1} r with D the diagonal of A.
class JacobiPreconditioner final : public Preconditioner {
 public:
  explicit JacobiPreconditioner(const Vector& diagonal) { update(diagonal); }
  explicit JacobiPreconditioner(const Csr& A) : JacobiPreconditioner(A.diagonal()) {}
  explicit JacobiPreconditioner(const Bcsr& A) : JacobiPreconditioner(A.diagonal()) {}
  void update(const Vector& diagonal);

  index_t rows() const override { return static_cast<index_t>(inv_diag_.size()); }
  index_t cols() const override { return rows(); }
  std::string name() const override { return "jacobi"; }
  const Vector& inverse_diagonal() const { return inv_diag_; }

 private:
  void apply_impl(const Vector& r, Vector& z) const override;
  Vector inv_diag_;
};

/// z_I = D_I^{-1} r_I with D_I the 3x3 diagonal blocks of A (inverted once per update()).
class BlockJacobiPreconditioner final : public Preconditioner {
 public:
  explicit BlockJacobiPreconditioner(const Bcsr& A) { update(A); }
  /// From diagonal blocks, 9 doubles each, row-major.
  explicit BlockJacobiPreconditioner(const std::vector<double>& diagonal_blocks) {
    update(diagonal_blocks);
  }
  void update(const Bcsr& A) { update(A.diagonal_blocks()); }
  void update(const std::vector<double>& diagonal_blocks);

  index_t rows() const override { return static_cast<index_t>(inv_blocks_.size() / 3); }
  index_t cols() const override { return rows(); }
  std::string name() const override { return "block-jacobi"; }
  /// Inverted diagonal blocks, 9 doubles each, row-major (used by the merged CG's fused step).
  const std::vector<double>& inverse_blocks() const { return inv_blocks_; }

 private:
  void apply_impl(const Vector& r, Vector& z) const override;
  std::vector<double> inv_blocks_;
};

}  // namespace pmg
