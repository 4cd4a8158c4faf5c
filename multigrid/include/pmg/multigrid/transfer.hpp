// pmg/multigrid/transfer.hpp — transfer of 3-component (displacement) vectors between levels.
//
// A scalar prolongation P (fine nodes x coarse nodes) acts on each of the three components:
// P ⊗ I₃. Restriction is R = Pᵀ by default (variationally consistent: keeps the V-cycle symmetric,
// so it can precondition CG), or any other scalar R (coarse x fine) given explicitly, such as the
// seed's interpolating restriction. Both are stored as CSR so that both directions run in parallel
// over rows.
#pragma once

#include "pmg/sparse/bcsr.hpp"

#include <memory>
#include <vector>

namespace pmg::mg {

/// The transfer of 3-component vectors between two adjacent levels: P ⊗ I₃ and R ⊗ I₃ (see the file
/// comment).
class BlockTransfer {
 public:
  /// R = Pᵀ.
  explicit BlockTransfer(Csr P);
  /// An explicit restriction (coarse x fine); the cycle is then not symmetric in general.
  BlockTransfer(Csr P, Csr R);

  index_t fine_size() const { return 3 * P_.rows(); }    ///< in unknowns
  index_t coarse_size() const { return 3 * P_.cols(); }  ///< in unknowns
  /// True when R = Pᵀ (built by the one-argument constructor).
  bool restriction_is_transpose() const { return transpose_; }
  /// The scalar prolongation P (fine nodes x coarse nodes).
  const Csr& prolongation() const { return P_; }
  /// The scalar restriction R (coarse nodes x fine nodes), Pᵀ unless given.
  const Csr& restriction() const { return R_; }

  /// xf = (P ⊗ I₃) xc
  void prolongate(const Vector& xc, Vector& xf) const;
  /// xf += (P ⊗ I₃) xc
  void prolongate_add(const Vector& xc, Vector& xf) const;
  /// rc = (R ⊗ I₃) rf
  void restrict_to_coarse(const Vector& rf, Vector& rc) const;

 private:
  Csr P_, R_;
  bool transpose_ = true;
};

/// Galerkin coarse operator (R ⊗ I₃) A (P ⊗ I₃) as BCSR (two sparse products): the reference.
Bcsr galerkin_product(const BlockTransfer& T, const Bcsr& A);

/// The Galerkin coarse operator C = (R ⊗ I₃) A (P ⊗ I₃) kept across value updates: the pattern
/// of C and a plan — for every block of C the blocks of A and weights R_Ii P_jJ that sum into it —
/// are built once; update() then refreshes C's values only, C_IJ = Σ R_Ii P_jJ A_ij, in parallel
/// over the block rows of C without locks or allocation.
class GalerkinProduct {
 public:
  GalerkinProduct() = default;
  /// Builds C's pattern and plan and computes C from A (A's size must be T's fine size, else
  /// InputError).
  GalerkinProduct(const BlockTransfer& T, const Bcsr& A);
  /// New values of A on the pattern the product was built on (InputError otherwise).
  void update(const Bcsr& A);
  /// The coarse operator C (coarse x coarse, 3x3 blocks).
  const Bcsr& matrix() const { return C_; }

 private:
  Bcsr C_;
  std::shared_ptr<const BlockPattern> fine_pattern_;
  std::vector<offset_t> start_;      ///< per block of C: its terms [start_[c], start_[c+1])
  std::vector<offset_t> fine_slot_;  ///< the block of A of each term
  std::vector<double> weight_;       ///< R_Ii P_jJ of each term
};

}  // namespace pmg::mg
