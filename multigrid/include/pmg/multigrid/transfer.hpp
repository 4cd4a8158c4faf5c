// pmg/multigrid/transfer.hpp — transfer of 3-component (displacement) vectors between levels.
//
// A scalar prolongation P (fine nodes x coarse nodes) acts on each of the three components:
// P ⊗ I₃. Restriction is R = Pᵀ by default (variationally consistent: keeps the V-cycle symmetric,
// so it can precondition CG), or any other scalar R (coarse x fine) given explicitly, such as the
// seed's interpolating restriction. Both are stored as CSR so that both directions run in parallel
// over rows.
//
// Components constrained on their own (symmetry planes, rollers; LevelProvider::constrained_dofs)
// make the transfer M_f (P ⊗ I₃) M_c with M the diagonal 0/1 masks of the free components: a
// prolongation writes nothing into a constrained fine component and reads nothing from a
// constrained coarse one, a restriction the same in reverse, so the V-cycle stays symmetric and
// every coarse correction satisfies the constraints.
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

  /// Constrained components (1 per unknown; see the file comment) of the fine and the coarse
  /// level; either may be empty (none constrained). InputError for a mask of the wrong size, or
  /// masks with an explicit restriction.
  void constrain(std::vector<char> fine, std::vector<char> coarse);
  /// The fine level's constrained components (empty: none).
  const std::vector<char>& fine_constraints() const { return fine_mask_; }
  /// The coarse level's constrained components (empty: none).
  const std::vector<char>& coarse_constraints() const { return coarse_mask_; }
  /// The coarse unknowns no free fine unknown takes anything from under the fine mask `fine` (a
  /// coarse component whose every fine neighbour is constrained in that component): the
  /// constrained components of a Galerkin coarse level, whose rows would otherwise be zero.
  std::vector<char> unreachable_coarse(const std::vector<char>& fine) const;

  /// xf = (P ⊗ I₃) xc
  void prolongate(const Vector& xc, Vector& xf) const;
  /// xf += (P ⊗ I₃) xc
  void prolongate_add(const Vector& xc, Vector& xf) const;
  /// rc = (R ⊗ I₃) rf
  void restrict_to_coarse(const Vector& rf, Vector& rc) const;

 private:
  Csr P_, R_;
  bool transpose_ = true;
  std::vector<char> fine_mask_, coarse_mask_;
};

/// Galerkin coarse operator (R ⊗ I₃) A (P ⊗ I₃) as BCSR (two sparse products): the reference.
Bcsr galerkin_product(const BlockTransfer& T, const Bcsr& A);

/// The Galerkin coarse operator C = (R ⊗ I₃) A (P ⊗ I₃) kept across value updates (with the
/// transfer's masks, C = M_c R M_f A M_f P M_c, its constrained rows then identity-like, their
/// diagonal the largest of the node's other diagonal entries, or 1): C's pattern is built once,
/// row by row on the threads (a marker per coarse node: no list of terms is sorted or kept);
/// update() then recomputes C's values, C_IJ = Σ R_Ii A_ij P_jJ, row by row on the threads
/// without locks (each thread finds row I's blocks through a position per coarse node), reading A
/// in its own order and storing nothing beyond C.
class GalerkinProduct {
 public:
  GalerkinProduct() = default;
  /// Builds C's pattern and computes C from A (A's size must be T's fine size, else InputError).
  /// Keeps copies of T's scalar P and R (a few entries per fine node).
  GalerkinProduct(const BlockTransfer& T, const Bcsr& A);
  /// New values of A on the pattern the product was built on (InputError otherwise).
  void update(const Bcsr& A);
  /// The coarse operator C (coarse x coarse, 3x3 blocks).
  const Bcsr& matrix() const { return C_; }

 private:
  Bcsr C_;
  Csr R_, P_;  ///< the transfer's scalar restriction and prolongation
  std::shared_ptr<const BlockPattern> fine_pattern_;
  std::vector<char> fine_mask_, coarse_mask_;  ///< the transfer's constrained components
};

}  // namespace pmg::mg
