// pmg/sparse/csr.hpp — compressed sparse row matrix with its pattern split from its values.
//
// The pattern (row pointers, sorted column indices) is immutable and shared through a
// shared_ptr<const CsrPattern>; the values are a plain array in pattern order. Updating values on
// a fixed pattern (every time step of a corotational simulation) never reallocates.
#pragma once

#include "pmg/sparse/operator.hpp"

#include <Eigen/SparseCore>

#include <memory>
#include <vector>

namespace pmg {

/// A (row, column, value) entry, for building matrices from lists of entries.
using Triplet = Eigen::Triplet<double, index_t>;

/// The sparsity pattern of a CSR matrix (see the file comment): row pointers and sorted column
/// indices, without values.
struct CsrPattern {
  /// Number of rows.
  index_t rows = 0;
  /// Number of columns.
  index_t cols = 0;
  std::vector<offset_t> row_ptr{0};  ///< rows+1 entries
  std::vector<index_t> col_idx;      ///< sorted and unique within each row

  /// Number of stored entries (row_ptr[rows]).
  offset_t nnz() const { return row_ptr.back(); }
  /// Position of entry (i, j) in the value array, or -1 if it is not in the pattern. O(log row).
  offset_t find(index_t i, index_t j) const;
  /// Throws InputError if the arrays are inconsistent (sizes, ordering, range).
  void validate() const;
};

/// A scalar CSR matrix: a shared immutable pattern and its values (see the file comment).
class Csr final : public LinearOperator {
 public:
  /// This matrix (LinearOperator's capability query).
  const Csr* csr_matrix() const override { return this; }
  /// The empty 0x0 matrix.
  Csr() : pattern_(std::make_shared<CsrPattern>()) {}
  /// Shares `pattern` (validated) and takes the values, one per entry in pattern order. Throws
  /// InputError for a null or inconsistent pattern or a wrong number of values.
  Csr(std::shared_ptr<const CsrPattern> pattern, std::vector<double> values);

  /// Builds pattern and values from triplets; duplicates are summed. Throws on out-of-range indices.
  static Csr from_triplets(index_t rows, index_t cols, const std::vector<Triplet>& triplets);
  /// Copies any Eigen sparse matrix (explicit zeros are kept in the pattern).
  template <int Options, typename Index>
  static Csr from_eigen(const Eigen::SparseMatrix<double, Options, Index>& A);
  /// A copy as an Eigen row-major sparse matrix.
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> to_eigen() const;
  /// Aᵀ, every stored entry kept (explicit zeros too), columns sorted in each row: a counting
  /// sort by column, O(nnz + cols), with no triplets.
  Csr transposed() const;

  index_t rows() const override { return pattern_->rows; }
  index_t cols() const override { return pattern_->cols; }
  /// Number of stored entries (explicit zeros included).
  offset_t nnz() const { return pattern_->nnz(); }

  /// The pattern (row pointers and column indices).
  const CsrPattern& pattern() const { return *pattern_; }
  /// The pattern as the shared pointer other matrices of the same pattern can share.
  const std::shared_ptr<const CsrPattern>& shared_pattern() const { return pattern_; }
  /// Values in pattern order (nnz() of them).
  const std::vector<double>& values() const { return values_; }
  /// Mutable values in pattern order: write new values in place (the pattern stays).
  std::vector<double>& values() { return values_; }

  /// Overwrites the values from a matrix whose nonzeros all lie in this pattern (entries of the
  /// pattern absent from A become zero). Throws InputError if A has an entry outside the pattern.
  void set_values(const Csr& A);

  /// Raw kernel: y[0:rows) = A x. OpenMP parallel over rows.
  void multiply(const double* x, double* y) const;
  /// The main diagonal, min(rows, cols) entries (zero where the pattern has none).
  Vector diagonal() const;
  /// Whether the matrix is square and every |a_ij - a_ji| <= rel_tol max |a| (a missing entry
  /// counts as zero). Cost: one binary search per entry.
  bool is_symmetric(double rel_tol = 1e-12) const;

 private:
  void apply_impl(const Vector& x, Vector& y) const override;
  double apply_dot_impl(const Vector& x, Vector& y) const override;
  void residual_impl(const Vector& b, const Vector& x, Vector& r) const override;

  std::shared_ptr<const CsrPattern> pattern_;
  std::vector<double> values_;
};

template <int Options, typename Index>
Csr Csr::from_eigen(const Eigen::SparseMatrix<double, Options, Index>& A) {
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> R = A;  // converts storage order if needed
  R.makeCompressed();
  auto p = std::make_shared<CsrPattern>();
  p->rows = static_cast<index_t>(R.rows());
  p->cols = static_cast<index_t>(R.cols());
  p->row_ptr.assign(R.outerIndexPtr(), R.outerIndexPtr() + R.rows() + 1);
  p->col_idx.assign(R.innerIndexPtr(), R.innerIndexPtr() + R.nonZeros());
  return Csr(std::move(p), std::vector<double>(R.valuePtr(), R.valuePtr() + R.nonZeros()));
}

}  // namespace pmg
