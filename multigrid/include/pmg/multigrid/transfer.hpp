// pmg/multigrid/transfer.hpp — transfer of 3-component (displacement) vectors between levels.
//
// A scalar prolongation P (fine nodes x coarse nodes) acts on each of the three components:
// P ⊗ I₃. Restriction is R = Pᵀ by default (variationally consistent: keeps the V-cycle symmetric,
// so it can precondition CG), or any other scalar R (coarse x fine) given explicitly, such as the
// seed's interpolating restriction. Both are stored as CSR so that both directions run in parallel
// over rows.
#pragma once

#include "pmg/sparse/bcsr.hpp"

namespace pmg::mg {

class BlockTransfer {
 public:
  /// R = Pᵀ.
  explicit BlockTransfer(Csr P);
  /// An explicit restriction (coarse x fine); the cycle is then not symmetric in general.
  BlockTransfer(Csr P, Csr R);

  index_t fine_size() const { return 3 * P_.rows(); }    ///< in unknowns
  index_t coarse_size() const { return 3 * P_.cols(); }  ///< in unknowns
  bool restriction_is_transpose() const { return transpose_; }
  const Csr& prolongation() const { return P_; }
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

/// Galerkin coarse operator (R ⊗ I₃) A (P ⊗ I₃) as BCSR (two sparse products).
Bcsr galerkin_product(const BlockTransfer& T, const Bcsr& A);

}  // namespace pmg::mg
