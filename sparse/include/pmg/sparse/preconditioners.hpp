// pmg/sparse/preconditioners.hpp — diagonal preconditioners: point Jacobi and 3x3 block Jacobi.
// Set-up checks that the (block) diagonal is SPD and names the first row or block that is not.
// Both read A's diagonal at setup() and update() and keep nothing else of A.
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/solver.hpp"

#include <vector>

namespace pmg {

/// z = D^{-1} r with D the diagonal of A (CSR, BCSR or BIN-BCSR).
class JacobiPreconditioner final : public Solver {
 public:
  JacobiPreconditioner() = default;
  /// Constructs and sets up on A (see Solver::setup()); throws InputError for a diagonal entry
  /// that is not positive and finite.
  explicit JacobiPreconditioner(const LinearOperator& A) { setup(A); }
  std::string name() const override { return "jacobi"; }
  /// D⁻¹ as a vector (as of the last setup() or update()).
  const Vector& inverse_diagonal() const { return inv_diag_; }

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override { setup_impl(system()); }
  void apply_impl(const Vector& r, Vector& z) const override;
  Vector inv_diag_;
};

/// z_I = D_I^{-1} r_I with D_I the 3x3 diagonal blocks of A (inverted once per update()).
class BlockJacobiPreconditioner final : public Solver {
 public:
  BlockJacobiPreconditioner() = default;
  /// Constructs and sets up on A (see Solver::setup()); throws InputError for a diagonal block
  /// that is not SPD or an operator without 3x3 diagonal blocks.
  explicit BlockJacobiPreconditioner(const LinearOperator& A) { setup(A); }
  std::string name() const override { return "block-jacobi"; }
  /// Inverted diagonal blocks, 9 doubles each, row-major (used by the merged CG's fused step).
  const std::vector<double>& inverse_blocks() const { return inv_blocks_; }

 private:
  /// Checks the layout (check_interleaved()) and inverts the blocks.
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  void apply_impl(const Vector& r, Vector& z) const override;
  std::vector<double> inv_blocks_;
};

/// Inverts 3x3 diagonal blocks (9 doubles each, row-major) by Cholesky, in place of the argument
/// (pass a temporary, or std::move, to invert without a copy), on the OpenMP threads; throws
/// InputError naming `who` and the first block that is not SPD.
std::vector<double> invert_diagonal_blocks(std::vector<double> blocks, const std::string& who);

}  // namespace pmg
