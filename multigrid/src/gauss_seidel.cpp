#include "pmg/multigrid/smoothers.hpp"

#include "pmg/sparse/preconditioners.hpp"

#include <algorithm>
#include <string>

namespace pmg::mg {

std::vector<double> inverse_diagonal_blocks(const LinearOperator& A) {
  return invert_diagonal_blocks(diagonal_blocks_of(A, "smoother"), "smoother");
}

namespace {
std::vector<std::vector<index_t>> color_rows(const BlockPattern& p) {
  // Greedy: the smallest colour not taken by a neighbour (a column of the row) coloured before.
  std::vector<int> color(p.rows, -1);
  std::vector<index_t> taken_by;
  std::vector<std::vector<index_t>> out;
  for (index_t I = 0; I < p.rows; ++I) {
    for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k) {
      const int c = color[p.col_idx[k]];
      if (c < 0) continue;
      if (static_cast<size_t>(c) >= taken_by.size()) taken_by.resize(c + 1, -1);
      taken_by[c] = I;
    }
    int c = 0;
    while (static_cast<size_t>(c) < taken_by.size() && taken_by[c] == I) ++c;
    color[I] = c;
    if (static_cast<size_t>(c) >= out.size()) out.resize(c + 1);
    out[c].push_back(I);
  }
  return out;
}

/// Relaxes block row I whose blocks are [begin, end) of (cols, v).
inline void relax_row(const index_t* cols, const double* v, offset_t begin, offset_t end,
                      const double* inv, const Vector& b, Vector& x, index_t I) {
  double r0 = b[3 * I], r1 = b[3 * I + 1], r2 = b[3 * I + 2];
  for (offset_t k = begin; k < end; ++k) {
    const index_t J = cols[k];
    if (J == I) continue;
    const double* a = v + 9 * k;
    const double x0 = x[3 * J], x1 = x[3 * J + 1], x2 = x[3 * J + 2];
    r0 -= a[0] * x0 + a[1] * x1 + a[2] * x2;
    r1 -= a[3] * x0 + a[4] * x1 + a[5] * x2;
    r2 -= a[6] * x0 + a[7] * x1 + a[8] * x2;
  }
  const double* d = inv + 9 * I;
  x[3 * I] = d[0] * r0 + d[1] * r1 + d[2] * r2;
  x[3 * I + 1] = d[3] * r0 + d[4] * r1 + d[5] * r2;
  x[3 * I + 2] = d[6] * r0 + d[7] * r1 + d[8] * r2;
}
/// Point Gauss–Seidel on block row I: the off-diagonal blocks as relax_row, then the 3x3 diagonal
/// block d relaxed scalar by scalar (forward: 0,1,2; backward: 2,1,0).
inline void relax_row_pointwise(const index_t* cols, const double* v, offset_t begin, offset_t end,
                                const double* diag, const Vector& b, Vector& x, index_t I, bool forward) {
  double r[3] = {b[3 * I], b[3 * I + 1], b[3 * I + 2]};
  for (offset_t k = begin; k < end; ++k) {
    const index_t J = cols[k];
    if (J == I) continue;
    const double* a = v + 9 * k;
    const double x0 = x[3 * J], x1 = x[3 * J + 1], x2 = x[3 * J + 2];
    r[0] -= a[0] * x0 + a[1] * x1 + a[2] * x2;
    r[1] -= a[3] * x0 + a[4] * x1 + a[5] * x2;
    r[2] -= a[6] * x0 + a[7] * x1 + a[8] * x2;
  }
  const double* d = diag + 9 * I;
  double* xi = x.data() + 3 * I;
  for (int s = 0; s < 3; ++s) {
    const int i = forward ? s : 2 - s;
    double ri = r[i];
    for (int j = 0; j < 3; ++j)
      if (j != i) ri -= d[3 * i + j] * xi[j];
    xi[i] = ri / d[4 * i];
  }
}
}  // namespace

BlockGaussSeidel::BlockGaussSeidel(const GaussSeidelParams& params) : params_(params) {
  if (params.sweeps < 1)
    throw InputError("Gauss-Seidel: sweeps must be >= 1 (a smoother that does nothing leaves the cycle without smoothing)");
}

void BlockGaussSeidel::setup_impl(const LinearOperator& op) {
  const Bcsr& A = as_bcsr(op, "Gauss-Seidel");
  A_ = &A;
  colors_.clear(), order_.clear(), color_start_.clear(), source_.clear();
  colored_ = BlockPattern{};
  if (params_.ordering == Ordering::multicolor) {
    colors_ = color_rows(A.pattern());
    const BlockPattern& p = A.pattern();
    colored_.rows = colored_.cols = p.rows;
    colored_.row_ptr.assign(1, 0);
    color_start_.assign(1, 0);
    for (const auto& rows : colors_) {
      for (index_t I : rows) {
        order_.push_back(I);
        for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k) {
          colored_.col_idx.push_back(p.col_idx[k]);
          source_.push_back(k);
        }
        colored_.row_ptr.push_back(static_cast<offset_t>(colored_.col_idx.size()));
      }
      color_start_.push_back(static_cast<index_t>(order_.size()));
    }
    colored_values_.resize(9 * source_.size());
  } else {
    colors_.assign(1, std::vector<index_t>(A.block_rows()));
    for (index_t I = 0; I < A.block_rows(); ++I) colors_[0][I] = I;
  }
  update_impl();
}

void BlockGaussSeidel::update_impl() {
  inv_diag_ = inverse_diagonal_blocks(*A_);  // also refuses diagonal blocks that are not SPD
  if (params_.pointwise) diag_ = A_->diagonal_blocks();
  const double* src = A_->values().data();
  double* dst = colored_values_.data();
  const offset_t n = static_cast<offset_t>(source_.size());
#pragma omp parallel for schedule(static)
  for (offset_t k = 0; k < n; ++k) std::copy_n(src + 9 * source_[k], 9, dst + 9 * k);
}

void BlockGaussSeidel::sweep(const Vector& b, Vector& x, bool forward) const {
  const double* inv = inv_diag_.data();
  if (params_.ordering == Ordering::multicolor) {
    const offset_t* rp = colored_.row_ptr.data();
    const index_t* cols = colored_.col_idx.data();
    const double* v = colored_values_.data();
    const int nc = static_cast<int>(colors_.size());
    for (int ci = 0; ci < nc; ++ci) {
      const int c = forward ? ci : nc - 1 - ci;
      // Rows of one colour are not coupled: any order, any thread; their blocks are contiguous.
      if (params_.pointwise) {
#pragma omp parallel for schedule(static)
        for (index_t k = color_start_[c]; k < color_start_[c + 1]; ++k)
          relax_row_pointwise(cols, v, rp[k], rp[k + 1], diag_.data(), b, x, order_[k], forward);
      } else {
#pragma omp parallel for schedule(static)
        for (index_t k = color_start_[c]; k < color_start_[c + 1]; ++k)
          relax_row(cols, v, rp[k], rp[k + 1], inv, b, x, order_[k]);
      }
    }
    return;
  }
  const BlockPattern& p = A_->pattern();
  const double* v = A_->values().data();
  const index_t n = p.rows;
  if (params_.pointwise) {
    for (index_t s = 0; s < n; ++s) {
      const index_t I = forward ? s : n - 1 - s;
      relax_row_pointwise(p.col_idx.data(), v, p.row_ptr[I], p.row_ptr[I + 1], diag_.data(), b, x, I, forward);
    }
    return;
  }
  if (forward) {
    for (index_t I = 0; I < n; ++I) relax_row(p.col_idx.data(), v, p.row_ptr[I], p.row_ptr[I + 1], inv, b, x, I);
  } else {
    for (index_t I = n - 1; I >= 0; --I) relax_row(p.col_idx.data(), v, p.row_ptr[I], p.row_ptr[I + 1], inv, b, x, I);
  }
}

void BlockGaussSeidel::pre_smooth(const Vector& b, Vector& x) const {
  for (int s = 0; s < params_.sweeps; ++s) sweep(b, x, true);
}

void BlockGaussSeidel::post_smooth(const Vector& b, Vector& x) const {
  for (int s = 0; s < params_.sweeps; ++s) sweep(b, x, false);
}

}  // namespace pmg::mg
