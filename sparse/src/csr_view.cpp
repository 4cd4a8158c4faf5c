#include "pmg/sparse/csr_view.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace pmg {

void CsrView::validate(const std::string& who, bool sorted) const {
  if (rows < 0 || cols < 0 || nnz < 0) throw InputError(who + ": negative size");
  if ((row_ptr_bytes != 4 && row_ptr_bytes != 8) || (col_idx_bytes != 4 && col_idx_bytes != 8))
    throw InputError(who + ": index arrays must be 32- or 64-bit integers");
  if (!row_ptr || (nnz > 0 && (!col_idx || !values))) throw InputError(who + ": missing arrays");
  if (ptr(0) != 0 || ptr(rows) != nnz)
    throw InputError(who + ": row pointers must run from 0 to the number of entries (" +
                     std::to_string(nnz) + ")");
  // Every row pointer first: with ptr(0) = 0 and ptr(rows) = nnz, non-decreasing pointers keep
  // every index read below inside the arrays.
  for (index_t i = 0; i < rows; ++i)
    if (ptr(i + 1) < ptr(i)) throw InputError(who + ": row pointers decrease at row " + std::to_string(i));
  for (index_t i = 0; i < rows; ++i) {
    const offset_t b = ptr(i), e = ptr(i + 1);
    for (offset_t k = b; k < e; ++k) {
      const std::int64_t j = col_idx_bytes == 4 ? static_cast<const std::int32_t*>(col_idx)[k]
                                                : static_cast<const std::int64_t*>(col_idx)[k];
      if (j < 0 || j >= cols)
        throw InputError(who + ": column index " + std::to_string(j) + " out of range in row " +
                         std::to_string(i));
      if (sorted && k > b && j <= col(k - 1))
        throw InputError(who + ": column indices of row " + std::to_string(i) +
                         " are not sorted and unique (sort and sum duplicates first)");
      if (!std::isfinite(values[k]))
        throw InputError(who + ": non-finite value in row " + std::to_string(i));
    }
  }
}

bool CsrView::is_canonical() const {
  for (index_t i = 0; i < rows; ++i)
    for (offset_t k = row_begin(i) + 1; k < row_end(i); ++k)
      if (col(k) <= col(k - 1)) return false;
  return true;
}

bool CsrView::same_pattern(const CsrView& o) const {
  if (rows != o.rows || cols != o.cols || nnz != o.nnz) return false;
  for (index_t i = 0; i <= rows; ++i)
    if (ptr(i) != o.ptr(i)) return false;
  for (offset_t k = 0; k < nnz; ++k)
    if (col(k) != o.col(k)) return false;
  return true;
}

CsrView view_of(const Csr& A) {
  CsrView v;
  v.rows = A.rows();
  v.cols = A.cols();
  v.nnz = A.nnz();
  v.row_ptr = A.pattern().row_ptr.data();
  v.row_ptr_bytes = sizeof(offset_t);
  v.col_idx = A.pattern().col_idx.data();
  v.col_idx_bytes = sizeof(index_t);
  v.values = A.values().data();
  return v;
}

Csr to_csr(const CsrView& A, const std::string& who) {
  A.validate(who, false);
  if (!A.is_canonical()) {  // each row sorted, duplicates summed
    std::vector<Triplet> t;
    t.reserve(static_cast<size_t>(A.nnz));
    for (index_t i = 0; i < A.rows; ++i)
      for (offset_t k = A.row_begin(i); k < A.row_end(i); ++k) t.emplace_back(i, A.col(k), A.values[k]);
    return Csr::from_triplets(A.rows, A.cols, t);
  }
  auto p = std::make_shared<CsrPattern>();
  p->rows = A.rows;
  p->cols = A.cols;
  p->row_ptr.resize(A.rows + 1);
  for (index_t i = 0; i <= A.rows; ++i) p->row_ptr[i] = i < A.rows ? A.row_begin(i) : A.nnz;
  p->col_idx.resize(A.nnz);
  if (A.col_idx_bytes == 4)
    std::memcpy(p->col_idx.data(), A.col_idx, sizeof(index_t) * A.nnz);
  else
    for (offset_t k = 0; k < A.nnz; ++k) p->col_idx[k] = A.col(k);
  return Csr(std::move(p), std::vector<double>(A.values, A.values + A.nnz));
}

}  // namespace pmg
