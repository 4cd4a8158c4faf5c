#include "pmg/sparse/csr.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

namespace pmg {

offset_t CsrPattern::find(index_t i, index_t j) const {
  if (i < 0 || i >= rows) return -1;
  const auto first = col_idx.begin() + row_ptr[i];
  const auto last = col_idx.begin() + row_ptr[i + 1];
  const auto it = std::lower_bound(first, last, j);
  return (it != last && *it == j) ? static_cast<offset_t>(it - col_idx.begin()) : -1;
}

void CsrPattern::validate() const {
  if (rows < 0 || cols < 0) throw InputError("CSR pattern: negative size");
  if (row_ptr.size() != static_cast<size_t>(rows) + 1)
    throw InputError("CSR pattern: row_ptr has " + std::to_string(row_ptr.size()) +
                     " entries, expected rows+1 = " + std::to_string(rows + 1));
  if (row_ptr[0] != 0) throw InputError("CSR pattern: row_ptr[0] must be 0");
  if (static_cast<size_t>(row_ptr.back()) != col_idx.size())
    throw InputError("CSR pattern: row_ptr[rows] does not match the number of column indices");
  for (index_t i = 0; i < rows; ++i) {
    if (row_ptr[i + 1] < row_ptr[i])
      throw InputError("CSR pattern: row_ptr decreases at row " + std::to_string(i));
    for (offset_t k = row_ptr[i]; k < row_ptr[i + 1]; ++k) {
      const index_t j = col_idx[k];
      if (j < 0 || j >= cols)
        throw InputError("CSR pattern: column " + std::to_string(j) + " out of range in row " +
                         std::to_string(i));
      if (k > row_ptr[i] && col_idx[k - 1] >= j)
        throw InputError("CSR pattern: columns of row " + std::to_string(i) +
                         " are not sorted and unique");
    }
  }
}

Csr::Csr(std::shared_ptr<const CsrPattern> pattern, std::vector<double> values)
    : pattern_(std::move(pattern)), values_(std::move(values)) {
  if (!pattern_) throw InputError("CSR: null pattern");
  pattern_->validate();
  if (values_.size() != static_cast<size_t>(pattern_->nnz()))
    throw InputError("CSR: " + std::to_string(values_.size()) + " values for a pattern of " +
                     std::to_string(pattern_->nnz()) + " entries");
}

Csr Csr::from_triplets(index_t rows, index_t cols, const std::vector<Triplet>& triplets) {
  if (rows < 0 || cols < 0) throw InputError("CSR: negative size");
  for (const auto& t : triplets)
    if (t.row() < 0 || t.row() >= rows || t.col() < 0 || t.col() >= cols)
      throw InputError("CSR: triplet (" + std::to_string(t.row()) + ", " + std::to_string(t.col()) +
                       ") outside a " + std::to_string(rows) + "x" + std::to_string(cols) +
                       " matrix");
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> A(rows, cols);
  A.setFromTriplets(triplets.begin(), triplets.end());
  return from_eigen(A);
}

Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> Csr::to_eigen() const {
  const CsrPattern& p = *pattern_;
  Eigen::SparseMatrix<double, Eigen::RowMajor, index_t> A(p.rows, p.cols);
  std::vector<Triplet> t;
  t.reserve(values_.size());
  for (index_t i = 0; i < p.rows; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      t.emplace_back(i, p.col_idx[k], values_[k]);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

Csr Csr::transposed() const {
  const CsrPattern& a = *pattern_;
  auto t = std::make_shared<CsrPattern>();
  t->rows = a.cols;
  t->cols = a.rows;
  t->row_ptr.assign(static_cast<size_t>(a.cols) + 1, 0);
  for (offset_t k = 0; k < a.nnz(); ++k) ++t->row_ptr[a.col_idx[k] + 1];
  for (index_t j = 0; j < a.cols; ++j) t->row_ptr[j + 1] += t->row_ptr[j];
  t->col_idx.resize(a.nnz());
  std::vector<double> v(a.nnz());
  std::vector<offset_t> next(t->row_ptr.begin(), t->row_ptr.end() - 1);
  for (index_t i = 0; i < a.rows; ++i)  // rows in order: each column's entries come out sorted
    for (offset_t k = a.row_ptr[i]; k < a.row_ptr[i + 1]; ++k) {
      const offset_t dst = next[a.col_idx[k]]++;
      t->col_idx[dst] = i;
      v[dst] = values_[k];
    }
  return Csr(std::move(t), std::move(v));
}

void Csr::set_values(const Csr& A) {
  if (A.rows() != rows() || A.cols() != cols())
    throw InputError("CSR set_values: size mismatch");
  const CsrPattern& a = A.pattern();
  std::fill(values_.begin(), values_.end(), 0.0);
  for (index_t i = 0; i < a.rows; ++i)
    for (offset_t k = a.row_ptr[i]; k < a.row_ptr[i + 1]; ++k) {
      const offset_t pos = pattern_->find(i, a.col_idx[k]);
      if (pos < 0)
        throw InputError("CSR set_values: entry (" + std::to_string(i) + ", " +
                         std::to_string(a.col_idx[k]) + ") is not in the pattern");
      values_[pos] = A.values()[k];
    }
}

void Csr::multiply(const double* x, double* y) const {
  const CsrPattern& p = *pattern_;
  const offset_t* rp = p.row_ptr.data();
  const index_t* ci = p.col_idx.data();
  const double* v = values_.data();
#pragma omp parallel for schedule(static)
  for (index_t i = 0; i < p.rows; ++i) {
    double sum = 0.0;
    for (offset_t k = rp[i]; k < rp[i + 1]; ++k) sum += v[k] * x[ci[k]];
    y[i] = sum;
  }
}

void Csr::apply_impl(const Vector& x, Vector& y) const { multiply(x.data(), y.data()); }

double Csr::apply_dot_impl(const Vector& x, Vector& y) const {
  check_square("apply_dot");
  const CsrPattern& p = *pattern_;
  const offset_t* rp = p.row_ptr.data();
  const index_t* ci = p.col_idx.data();
  const double* v = values_.data();
  const double* xp = x.data();
  double* yp = y.data();
  double dot = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : dot)
  for (index_t i = 0; i < p.rows; ++i) {
    double sum = 0.0;
    for (offset_t k = rp[i]; k < rp[i + 1]; ++k) sum += v[k] * xp[ci[k]];
    yp[i] = sum;
    dot += sum * xp[i];
  }
  return dot;
}

void Csr::residual_impl(const Vector& b, const Vector& x, Vector& r) const {
  const CsrPattern& p = *pattern_;
  const offset_t* rp = p.row_ptr.data();
  const index_t* ci = p.col_idx.data();
  const double* v = values_.data();
  const double* xp = x.data();
#pragma omp parallel for schedule(static)
  for (index_t i = 0; i < p.rows; ++i) {
    double sum = b[i];
    for (offset_t k = rp[i]; k < rp[i + 1]; ++k) sum -= v[k] * xp[ci[k]];
    r[i] = sum;
  }
}

Vector Csr::diagonal() const {
  const index_t n = std::min(rows(), cols());
  Vector d = Vector::Zero(n);
  for (index_t i = 0; i < n; ++i) {
    const offset_t k = pattern_->find(i, i);
    if (k >= 0) d[i] = values_[k];
  }
  return d;
}

bool Csr::is_symmetric(double rel_tol) const {
  if (rows() != cols()) return false;
  double max_abs = 0.0;
  for (double v : values_) max_abs = std::max(max_abs, std::abs(v));
  const CsrPattern& p = *pattern_;
  for (index_t i = 0; i < p.rows; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
      const offset_t kt = p.find(p.col_idx[k], i);
      const double vt = kt >= 0 ? values_[kt] : 0.0;
      if (std::abs(values_[k] - vt) > rel_tol * max_abs) return false;
    }
  return true;
}

}  // namespace pmg
