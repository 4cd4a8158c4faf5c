#include "pmg/multigrid/transfer.hpp"
#include "pmg/sparse/pattern_rows.hpp"

#include <algorithm>

namespace pmg::mg {

namespace {

/// y[3i+c] (+)= Σ_j M_ij x[3j+c]; with masks (1 per unknown, empty: none) x's masked entries
/// read as 0 and y's masked entries are set to 0 (not added to).
template <bool Add>
void block_multiply(const Csr& M, const Vector& x, Vector& y, const std::vector<char>& x_mask = {},
                    const std::vector<char>& y_mask = {}) {
  const CsrPattern& p = M.pattern();
  const double* v = M.values().data();
  const char* xm = x_mask.empty() ? nullptr : x_mask.data();
  const char* ym = y_mask.empty() ? nullptr : y_mask.data();
#pragma omp parallel for schedule(static)
  for (index_t i = 0; i < p.rows; ++i) {
    double s[3] = {0, 0, 0};
    if (xm) {
      for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
        const double w = v[k];
        const Eigen::Index j = 3 * static_cast<Eigen::Index>(p.col_idx[k]);
        for (int c = 0; c < 3; ++c) s[c] += xm[j + c] ? 0.0 : w * x[j + c];
      }
    } else {
      for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
        const double w = v[k];
        const Eigen::Index j = 3 * static_cast<Eigen::Index>(p.col_idx[k]);
        s[0] += w * x[j];
        s[1] += w * x[j + 1];
        s[2] += w * x[j + 2];
      }
    }
    for (int c = 0; c < 3; ++c) {
      const Eigen::Index r = 3 * static_cast<Eigen::Index>(i) + c;
      if (ym && ym[r]) {
        if (!Add) y[r] = 0.0;
      } else if (Add) {
        y[r] += s[c];
      } else {
        y[r] = s[c];
      }
    }
  }
}

Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> kron_i3(const Csr& M) {
  std::vector<Triplet> t;
  const CsrPattern& p = M.pattern();
  t.reserve(3 * M.nnz());
  for (index_t i = 0; i < p.rows; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      for (int c = 0; c < 3; ++c) t.emplace_back(3 * i + c, 3 * p.col_idx[k] + c, M.values()[k]);
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> K(3 * M.rows(), 3 * M.cols());
  K.setFromTriplets(t.begin(), t.end());
  return K;
}
}  // namespace

BlockTransfer::BlockTransfer(Csr P) : P_(std::move(P)), R_(P_.transposed()), transpose_(true) {}

BlockTransfer::BlockTransfer(Csr P, Csr R) : P_(std::move(P)), R_(std::move(R)), transpose_(false) {
  if (R_.rows() != P_.cols() || R_.cols() != P_.rows())
    throw InputError("transfer: restriction must be coarse x fine (" + std::to_string(P_.cols()) +
                     " x " + std::to_string(P_.rows()) + ")");
}

void BlockTransfer::constrain(std::vector<char> fine, std::vector<char> coarse) {
  if (!transpose_ && (!fine.empty() || !coarse.empty()))
    throw InputError("transfer: constrained components need the restriction Pᵀ, not an explicit one "
                     "(an interpolating restriction would not keep the cycle symmetric under the masks)");
  if ((!fine.empty() && static_cast<index_t>(fine.size()) != fine_size()) ||
      (!coarse.empty() && static_cast<index_t>(coarse.size()) != coarse_size()))
    throw InputError("transfer: constrained components need one flag per unknown (" + std::to_string(fine_size()) +
                     " fine, " + std::to_string(coarse_size()) + " coarse), got " + std::to_string(fine.size()) +
                     " and " + std::to_string(coarse.size()));
  fine_mask_ = std::move(fine);
  coarse_mask_ = std::move(coarse);
}

std::vector<char> BlockTransfer::unreachable_coarse(const std::vector<char>& fine) const {
  if (!fine.empty() && static_cast<index_t>(fine.size()) != fine_size())
    throw InputError("transfer: a fine mask of " + std::to_string(fine.size()) + " flags for " +
                     std::to_string(fine_size()) + " unknowns");
  std::vector<char> reached(coarse_size(), 0);
  const CsrPattern& p = P_.pattern();
  for (index_t i = 0; i < p.rows; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      if (P_.values()[k] != 0.0)
        for (int c = 0; c < 3; ++c)
          if (fine.empty() || !fine[3 * i + c]) reached[3 * p.col_idx[k] + c] = 1;
  for (char& r : reached) r = !r;
  return reached;
}

void BlockTransfer::prolongate(const Vector& xc, Vector& xf) const {
  if (xc.size() != coarse_size()) throw InputError("prolongate: coarse vector has the wrong size");
  xf.resize(fine_size());
  block_multiply<false>(P_, xc, xf, coarse_mask_, fine_mask_);
}

void BlockTransfer::prolongate_add(const Vector& xc, Vector& xf) const {
  if (xc.size() != coarse_size() || xf.size() != fine_size())
    throw InputError("prolongate_add: vector sizes do not match the transfer");
  block_multiply<true>(P_, xc, xf, coarse_mask_, fine_mask_);
}

void BlockTransfer::restrict_to_coarse(const Vector& rf, Vector& rc) const {
  if (rf.size() != fine_size()) throw InputError("restrict: fine vector has the wrong size");
  rc.resize(coarse_size());
  block_multiply<false>(R_, rf, rc, fine_mask_, coarse_mask_);
}

Bcsr galerkin_product(const BlockTransfer& T, const Bcsr& A) {
  if (A.rows() != T.fine_size()) throw InputError("Galerkin product: matrix size does not match the transfer");
  if (!T.fine_constraints().empty() || !T.coarse_constraints().empty())
    throw InputError("Galerkin product: the reference product takes no constrained components (use GalerkinProduct)");
  const auto P = kron_i3(T.prolongation());
  const auto R = kron_i3(T.restriction());
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> AP = A.to_csr().to_eigen() * P;
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> RAP = R * AP;
  return Bcsr::from_csr(Csr::from_eigen(RAP));
}

GalerkinProduct::GalerkinProduct(const BlockTransfer& T, const Bcsr& A)
    : R_(T.restriction()), P_(T.prolongation()), fine_pattern_(A.shared_pattern()),
      fine_mask_(T.fine_constraints()), coarse_mask_(T.coarse_constraints()) {
  if (A.rows() != T.fine_size()) throw InputError("Galerkin product: matrix size does not match the transfer");
  const CsrPattern& R = R_.pattern();
  const CsrPattern& P = P_.pattern();
  const BlockPattern& a = A.pattern();
  // C's pattern: the coarse nodes J reached from row I through R_I·, A and P.
  const auto pattern = pattern_by_rows(R.rows, R.rows, [&](index_t I, auto&& add) {
    for (offset_t k = R.row_ptr[I]; k < R.row_ptr[I + 1]; ++k) {
      const index_t i = R.col_idx[k];
      for (offset_t s = a.row_ptr[i]; s < a.row_ptr[i + 1]; ++s) {
        const index_t j = a.col_idx[s];
        for (offset_t m = P.row_ptr[j]; m < P.row_ptr[j + 1]; ++m) add(P.col_idx[m]);
      }
    }
  });
  C_ = Bcsr(pattern, std::vector<double>(9 * pattern->col_idx.size(), 0.0));
  update(A);
}

void GalerkinProduct::update(const Bcsr& A) {
  if (A.shared_pattern() != fine_pattern_ && !(A.pattern().row_ptr == fine_pattern_->row_ptr &&
                                               A.pattern().col_idx == fine_pattern_->col_idx))
    throw InputError("Galerkin product: the fine matrix's pattern changed (build a new product)");
  const CsrPattern& R = R_.pattern();
  const CsrPattern& P = P_.pattern();
  const double* rv = R_.values().data();
  const double* pv = P_.values().data();
  const BlockPattern& a = A.pattern();
  const BlockPattern& c = C_.pattern();
  const index_t nc = C_.block_rows();
  const bool masked = !fine_mask_.empty();
  // C_I· = Σ_i R_Ii Σ_j A_ij P_j·, row by row on the threads: the blocks of row I found through
  // a position per coarse node (set from C's pattern, cleared after the row).
#pragma omp parallel
  {
    std::vector<offset_t> position(nc, -1);
#pragma omp for schedule(dynamic, 64)
    for (index_t I = 0; I < nc; ++I) {
      for (offset_t q = c.row_ptr[I]; q < c.row_ptr[I + 1]; ++q) {
        position[c.col_idx[q]] = q;
        C_.block(q).setZero();
      }
      for (offset_t k = R.row_ptr[I]; k < R.row_ptr[I + 1]; ++k) {
        const index_t i = R.col_idx[k];
        for (offset_t s = a.row_ptr[i]; s < a.row_ptr[i + 1]; ++s) {
          const index_t j = a.col_idx[s];
          Block3 b = rv[k] * A.block(s);
          if (masked)  // M_f A M_f: constrained fine rows and columns (diagonal included) left out
            for (int r = 0; r < 3; ++r)
              for (int q = 0; q < 3; ++q)
                if (fine_mask_[3 * i + r] || fine_mask_[3 * j + q]) b(r, q) = 0.0;
          for (offset_t m = P.row_ptr[j]; m < P.row_ptr[j + 1]; ++m) C_.block(position[P.col_idx[m]]) += pv[m] * b;
        }
      }
      for (offset_t q = c.row_ptr[I]; q < c.row_ptr[I + 1]; ++q) position[c.col_idx[q]] = -1;
    }
  }
  if (coarse_mask_.empty()) return;
  // Constrained coarse components: rows and columns zeroed, the diagonal the largest of the
  // node's free diagonal entries (1 when none), so that the row scales like its neighbours.
  const BlockPattern& p = C_.pattern();
#pragma omp parallel for schedule(static)
  for (index_t I = 0; I < nc; ++I)
    for (offset_t c = p.row_ptr[I]; c < p.row_ptr[I + 1]; ++c) {
      const index_t J = p.col_idx[c];
      auto b = C_.block(c);
      double scale = 0.0;
      if (J == I)
        for (int r = 0; r < 3; ++r)
          if (!coarse_mask_[3 * I + r]) scale = std::max(scale, b(r, r));
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q)
          if (coarse_mask_[3 * I + r] || coarse_mask_[3 * J + q]) b(r, q) = (J == I && r == q) ? (scale > 0 ? scale : 1.0) : 0.0;
    }
}

}  // namespace pmg::mg
