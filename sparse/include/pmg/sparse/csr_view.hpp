// pmg/sparse/csr_view.hpp — a CSR matrix held in someone else's arrays (SciPy, PETSc, a FEM code),
// read in place: 32- or 64-bit row pointers and column indices, double values. pmgkit builds its
// own formats from a view (Csr, BCSR, multigrid levels) without first widening the caller's index
// arrays, and refreshes values from a view of the same pattern without symbolic work. Rows may be
// in any column order and hold duplicates (deal.II's diagonal first, PETSc's unassembled
// triplets, a FEM code's element sums): duplicates are summed where pmgkit builds its own format.
#pragma once

#include "pmg/sparse/csr.hpp"

#include <string>

namespace pmg {

/// A CSR matrix in arrays owned by the caller, read in place (see the file comment). Nothing is
/// copied: the arrays must outlive every use of the view.
struct CsrView {
  /// Number of rows.
  index_t rows = 0, cols = 0;  ///< number of columns
  /// Number of stored entries.
  offset_t nnz = 0;
  const void* row_ptr = nullptr;  ///< rows+1 entries of row_ptr_bytes each
  int row_ptr_bytes = 8;          ///< 4 (int32) or 8 (int64)
  const void* col_idx = nullptr;  ///< nnz entries of col_idx_bytes each
  int col_idx_bytes = 4;          ///< 4 or 8
  const double* values = nullptr; ///< nnz values

  /// Position of row i's first entry (row_ptr[i]); i in [0, rows], unchecked.
  offset_t row_begin(index_t i) const { return ptr(i); }
  /// One past row i's last entry (row_ptr[i + 1]); i in [0, rows), unchecked.
  offset_t row_end(index_t i) const { return ptr(i + 1); }
  /// Column index of entry k; k in [0, nnz), unchecked.
  index_t col(offset_t k) const {
    return col_idx_bytes == 4 ? static_cast<const std::int32_t*>(col_idx)[k]
                              : static_cast<index_t>(static_cast<const std::int64_t*>(col_idx)[k]);
  }

  /// Throws InputError naming `who` unless the arrays form a CSR matrix: monotone row pointers
  /// from 0 to nnz, column indices in range, finite values, and with `sorted` (the default)
  /// column indices sorted and unique within each row. O(nnz), no allocation.
  void validate(const std::string& who, bool sorted = true) const;
  /// Whether every row's column indices are sorted and unique (canonical CSR). O(nnz).
  bool is_canonical() const;
  /// Whether the pattern (not the values) equals another view's.
  bool same_pattern(const CsrView& other) const;

 private:
  offset_t ptr(index_t i) const {
    return row_ptr_bytes == 4 ? static_cast<const std::int32_t*>(row_ptr)[i]
                              : static_cast<const std::int64_t*>(row_ptr)[i];
  }
};

/// A view of a Csr's own arrays.
CsrView view_of(const Csr& A);
/// pmgkit's CSR (64-bit row pointers, 32-bit columns) copied from a view (validated), each row's
/// columns sorted and duplicates summed when the view's are not.
Csr to_csr(const CsrView& A, const std::string& who);

}  // namespace pmg
