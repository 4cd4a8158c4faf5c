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

using Triplet = Eigen::Triplet<double, index_t>;

struct CsrPattern {
  index_t rows = 0;
  index_t cols = 0;
  std::vector<offset_t> row_ptr{0};  ///< rows+1 entries
  std::vector<index_t> col_idx;      ///< sorted and unique within each row

  offset_t nnz() const { return row_ptr.back(); }
  /// Position of entry (i, j) in the value array, or -1 if it is not in the pattern. O(log row).
  offset_t find(index_t i, index_t j) const;
  /// Throws InputError if the arrays are inconsistent (sizes, ordering, range).
  void validate() const;
};

class Csr final : public LinearOperator {
 public:
  Csr() : pattern_(std::make_shared<CsrPattern>()) {}
  Csr(std::shared_ptr<const CsrPattern> pattern, std::vector<double> values);

  /// Builds pattern and values from triplets; duplicates are summed. Throws on out-of-range indices.
  static Csr from_triplets(index_t rows, index_t cols, const std::vector<Triplet>& triplets);
  /// Copies any Eigen sparse matrix (explicit zeros are kept in the pattern).
  template <int Options, typename Index>
  static Csr from_eigen(const Eigen::SparseMatrix<double, Options, Index>& A);
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> to_eigen() const;

  index_t rows() const override { return pattern_->rows; }
  index_t cols() const override { return pattern_->cols; }
  offset_t nnz() const { return pattern_->nnz(); }

  const CsrPattern& pattern() const { return *pattern_; }
  const std::shared_ptr<const CsrPattern>& shared_pattern() const { return pattern_; }
  const std::vector<double>& values() const { return values_; }
  /// Mutable values in pattern order: write new values in place (the pattern stays).
  std::vector<double>& values() { return values_; }

  /// Overwrites the values from a matrix whose nonzeros all lie in this pattern (entries of the
  /// pattern absent from A become zero). Throws InputError if A has an entry outside the pattern.
  void set_values(const Csr& A);

  /// Raw kernel: y[0:rows) = A x. OpenMP parallel over rows.
  void multiply(const double* x, double* y) const;
  Vector diagonal() const;
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
