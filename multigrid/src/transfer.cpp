#include "pmg/multigrid/transfer.hpp"

#include <algorithm>

namespace pmg::mg {

namespace {
Csr transpose(const Csr& A) {
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> T = A.to_eigen().transpose();
  return Csr::from_eigen(T);
}

/// y[3i+c] (+)= Σ_j M_ij x[3j+c]
template <bool Add>
void block_multiply(const Csr& M, const Vector& x, Vector& y) {
  const CsrPattern& p = M.pattern();
  const double* v = M.values().data();
#pragma omp parallel for schedule(static)
  for (index_t i = 0; i < p.rows; ++i) {
    double s0 = 0, s1 = 0, s2 = 0;
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
      const double w = v[k];
      const Eigen::Index j = 3 * static_cast<Eigen::Index>(p.col_idx[k]);
      s0 += w * x[j];
      s1 += w * x[j + 1];
      s2 += w * x[j + 2];
    }
    if (Add) {
      y[3 * i] += s0, y[3 * i + 1] += s1, y[3 * i + 2] += s2;
    } else {
      y[3 * i] = s0, y[3 * i + 1] = s1, y[3 * i + 2] = s2;
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

BlockTransfer::BlockTransfer(Csr P) : P_(std::move(P)), R_(transpose(P_)), transpose_(true) {}

BlockTransfer::BlockTransfer(Csr P, Csr R) : P_(std::move(P)), R_(std::move(R)), transpose_(false) {
  if (R_.rows() != P_.cols() || R_.cols() != P_.rows())
    throw InputError("transfer: restriction must be coarse x fine (" + std::to_string(P_.cols()) +
                     " x " + std::to_string(P_.rows()) + ")");
}

void BlockTransfer::prolongate(const Vector& xc, Vector& xf) const {
  if (xc.size() != coarse_size()) throw InputError("prolongate: coarse vector has the wrong size");
  xf.resize(fine_size());
  block_multiply<false>(P_, xc, xf);
}

void BlockTransfer::prolongate_add(const Vector& xc, Vector& xf) const {
  if (xc.size() != coarse_size() || xf.size() != fine_size())
    throw InputError("prolongate_add: vector sizes do not match the transfer");
  block_multiply<true>(P_, xc, xf);
}

void BlockTransfer::restrict_to_coarse(const Vector& rf, Vector& rc) const {
  if (rf.size() != fine_size()) throw InputError("restrict: fine vector has the wrong size");
  rc.resize(coarse_size());
  block_multiply<false>(R_, rf, rc);
}

Bcsr galerkin_product(const BlockTransfer& T, const Bcsr& A) {
  if (A.rows() != T.fine_size()) throw InputError("Galerkin product: matrix size does not match the transfer");
  const auto P = kron_i3(T.prolongation());
  const auto R = kron_i3(T.restriction());
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> AP = A.to_csr().to_eigen() * P;
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> RAP = R * AP;
  return Bcsr::from_csr(Csr::from_eigen(RAP));
}

GalerkinProduct::GalerkinProduct(const BlockTransfer& T, const Bcsr& A) : fine_pattern_(A.shared_pattern()) {
  if (A.rows() != T.fine_size()) throw InputError("Galerkin product: matrix size does not match the transfer");
  const CsrPattern& R = T.restriction().pattern();
  const CsrPattern& P = T.prolongation().pattern();
  const std::vector<double>& rv = T.restriction().values();
  const std::vector<double>& pv = T.prolongation().values();
  const BlockPattern& a = A.pattern();
  const index_t nc = R.rows;
  auto pattern = std::make_shared<BlockPattern>();
  pattern->rows = pattern->cols = nc;
  pattern->row_ptr.assign(nc + 1, 0);
  start_.assign(1, 0);
  struct Term {
    index_t J;
    offset_t s;
    double w;
  };
  std::vector<Term> terms;
  for (index_t I = 0; I < nc; ++I) {
    terms.clear();
    for (offset_t k = R.row_ptr[I]; k < R.row_ptr[I + 1]; ++k) {
      const index_t i = R.col_idx[k];
      for (offset_t s = a.row_ptr[i]; s < a.row_ptr[i + 1]; ++s) {
        const index_t j = a.col_idx[s];
        for (offset_t m = P.row_ptr[j]; m < P.row_ptr[j + 1]; ++m) terms.push_back({P.col_idx[m], s, rv[k] * pv[m]});
      }
    }
    std::stable_sort(terms.begin(), terms.end(), [](const Term& x, const Term& y) { return x.J < y.J; });
    for (size_t t = 0; t < terms.size(); ++t) {
      if (t == 0 || terms[t].J != terms[t - 1].J) {
        if (t > 0) start_.push_back(static_cast<offset_t>(fine_slot_.size()));
        pattern->col_idx.push_back(terms[t].J);
      }
      fine_slot_.push_back(terms[t].s);
      weight_.push_back(terms[t].w);
    }
    if (!terms.empty()) start_.push_back(static_cast<offset_t>(fine_slot_.size()));
    pattern->row_ptr[I + 1] = static_cast<offset_t>(pattern->col_idx.size());
  }
  C_ = Bcsr(pattern, std::vector<double>(9 * pattern->col_idx.size(), 0.0));
  update(A);
}

void GalerkinProduct::update(const Bcsr& A) {
  if (A.shared_pattern() != fine_pattern_ && !(A.pattern().row_ptr == fine_pattern_->row_ptr &&
                                               A.pattern().col_idx == fine_pattern_->col_idx))
    throw InputError("Galerkin product: the fine matrix's pattern changed (build a new product)");
  const index_t nc = C_.block_rows();
  const offset_t* row_ptr = C_.pattern().row_ptr.data();
#pragma omp parallel for schedule(dynamic, 64)
  for (index_t I = 0; I < nc; ++I)
    for (offset_t c = row_ptr[I]; c < row_ptr[I + 1]; ++c) {
      Block3 sum = Block3::Zero();
      for (offset_t t = start_[c]; t < start_[c + 1]; ++t) sum += weight_[t] * A.block(fine_slot_[t]);
      C_.block(c) = sum;
    }
}

}  // namespace pmg::mg
