#include "pmg/sparse/bin_bcsr.hpp"

#include <algorithm>
#include <string>

namespace pmg {

namespace {
constexpr int W = BinBcsr::kBinRows;
constexpr int B = Bcsr::kBlock;
constexpr int BB = Bcsr::kBlockSize;

bool same_pattern(const BlockPattern& a, const BlockPattern& b) {
  return a.rows == b.rows && a.cols == b.cols && a.row_ptr == b.row_ptr && a.col_idx == b.col_idx;
}
}  // namespace

BinBcsr::BinBcsr(const Bcsr& A) {
  if (A.block_rows() != A.block_cols()) throw InputError("BIN-BCSR: matrix must be square");
  const BlockPattern& p = A.pattern();
  source_pattern_ = A.shared_pattern();
  source_blocks_ = A.num_blocks();
  block_rows_ = p.rows;
  const index_t n = 3 * block_rows_;
  const index_t nbins = (n + W - 1) / W;
  width_.resize(nbins);
  first_block_row_.resize(nbins);
  bin_block_rows_.resize(nbins);
  col_offset_.resize(nbins + 1);
  val_offset_.resize(nbins + 1);
  diag_source_.assign(block_rows_, -1);

  // Plan: per bin the block rows it touches and the longest off-diagonal block row among them.
  col_offset_[0] = val_offset_[0] = 0;
  for (index_t b = 0; b < nbins; ++b) {
    const index_t row0 = W * b, row1 = std::min(row0 + W, n);
    const index_t first = row0 / B, last = (row1 - 1) / B;
    index_t width = 0;
    for (index_t I = first; I <= last; ++I) {
      const index_t len = static_cast<index_t>(p.row_ptr[I + 1] - p.row_ptr[I]);
      width = std::max(width, len - (p.find(I, I) >= 0 ? 1 : 0));
    }
    width_[b] = width;
    first_block_row_[b] = first;
    bin_block_rows_[b] = last - first + 1;
    col_offset_[b + 1] = col_offset_[b] + static_cast<offset_t>(width) * (last - first + 1);
    val_offset_[b + 1] = val_offset_[b] + static_cast<offset_t>(width) * B * W;
  }
  columns_.assign(col_offset_[nbins], -1);
  source_block_.assign(col_offset_[nbins], -1);
  for (index_t b = 0; b < nbins; ++b) {
    const index_t nbr = bin_block_rows_[b];
    for (index_t l = 0; l < nbr; ++l) {
      const index_t I = first_block_row_[b] + l;
      index_t slot = 0;
      for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k) {
        if (p.col_idx[k] == I) {
          diag_source_[I] = k;
          continue;
        }
        const offset_t pos = col_offset_[b] + static_cast<offset_t>(slot) * nbr + l;
        columns_[pos] = p.col_idx[k];
        source_block_[pos] = k;
        ++slot;
      }
    }
  }
  values_.assign(val_offset_[nbins], 0.0);
  diag_.assign(BB * static_cast<size_t>(block_rows_), 0.0);
  update_values(A);
}

void BinBcsr::update_values(const Bcsr& A) {
  if (A.shared_pattern() != source_pattern_ && !same_pattern(A.pattern(), *source_pattern_))
    throw InputError("BIN-BCSR update_values: the matrix does not have the sliced pattern");
  const double* src = A.values().data();
  const index_t n = rows();
  const index_t nbins = num_bins();
#pragma omp parallel for schedule(static)
  for (index_t b = 0; b < nbins; ++b) {
    const index_t row0 = W * b, nrows = std::min(W, n - row0);
    const index_t nbr = bin_block_rows_[b];
    for (index_t k = 0; k < width_[b]; ++k)
      for (index_t r = 0; r < nrows; ++r) {
        const index_t row = row0 + r, l = row / B - first_block_row_[b];
        const offset_t s = source_block_[col_offset_[b] + static_cast<offset_t>(k) * nbr + l];
        double* dst = values_.data() + val_offset_[b] + static_cast<offset_t>(B * k) * W + r;
        for (int c = 0; c < B; ++c) dst[c * W] = s >= 0 ? src[BB * s + B * (row % B) + c] : 0.0;
      }
  }
  for (index_t I = 0; I < block_rows_; ++I) {
    const offset_t s = diag_source_[I];
    for (int e = 0; e < BB; ++e) diag_[BB * I + e] = s >= 0 ? src[BB * s + e] : 0.0;
  }
}

double BinBcsr::padding_ratio() const {
  if (source_blocks_ == 0) return 1.0;
  return static_cast<double>(values_.size() + diag_.size()) / (BB * static_cast<double>(source_blocks_));
}

double BinBcsr::bytes_per_spmv() const {
  return 8.0 * (values_.size() + diag_.size()) + 4.0 * columns_.size() + 2.0 * 8.0 * rows();
}

// Per bin: sum[r] = D x for its 32 rows, then for each block step k (column-major: the 32 rows read
// consecutive values) sum[r] += A[pos + 32c] * x[3 col + c]. On the CPU the rows of one block row
// are visited together so that its column index and x-block are read once, not three times.
void BinBcsr::multiply(const double* x, double* y) const {
  const index_t n = rows();
  const index_t nbins = num_bins();
#pragma omp parallel for schedule(static)
  for (index_t b = 0; b < nbins; ++b) {
    const index_t row0 = W * b, nrows = std::min(W, n - row0);
    const index_t first = first_block_row_[b], nbr = bin_block_rows_[b];
    double sum[W];
    for (index_t r = 0; r < nrows; ++r) {
      const index_t row = row0 + r, I = row / B;
      const double* d = diag_.data() + BB * I + B * (row % B);
      const double* xi = x + B * I;
      sum[r] = d[0] * xi[0] + d[1] * xi[1] + d[2] * xi[2];
    }
    const index_t* cols = columns_.data() + col_offset_[b];
    const double* vals = values_.data() + val_offset_[b];
    for (index_t k = 0; k < width_[b]; ++k) {
      const index_t* ck = cols + static_cast<offset_t>(k) * nbr;
      const double* vk = vals + static_cast<offset_t>(B * k) * W;
      for (index_t l = 0; l < nbr; ++l) {
        const index_t col = ck[l];
        if (col < 0) continue;  // padding
        const double* xj = x + B * static_cast<offset_t>(col);
        const double x0 = xj[0], x1 = xj[1], x2 = xj[2];
        // Rows of block row first+l that lie in this bin.
        const index_t r_begin = std::max<index_t>(B * (first + l) - row0, 0);
        const index_t r_end = std::min<index_t>(B * (first + l + 1) - row0, nrows);
        if (r_end - r_begin == B) {  // the common case: the whole block row is in this bin
          const index_t r = r_begin;
          sum[r] += vk[r] * x0 + vk[r + W] * x1 + vk[r + 2 * W] * x2;
          sum[r + 1] += vk[r + 1] * x0 + vk[r + 1 + W] * x1 + vk[r + 1 + 2 * W] * x2;
          sum[r + 2] += vk[r + 2] * x0 + vk[r + 2 + W] * x1 + vk[r + 2 + 2 * W] * x2;
        } else {
          for (index_t r = r_begin; r < r_end; ++r)
            sum[r] += vk[r] * x0 + vk[r + W] * x1 + vk[r + 2 * W] * x2;
        }
      }
    }
    std::copy_n(sum, nrows, y + row0);
  }
}

void BinBcsr::apply_impl(const Vector& x, Vector& y) const { multiply(x.data(), y.data()); }

}  // namespace pmg
