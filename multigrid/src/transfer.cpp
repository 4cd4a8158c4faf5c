#include "pmg/multigrid/transfer.hpp"

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

}  // namespace pmg::mg
