#include "pmg/sparse/bin_bcsr.hpp"

#include <algorithm>
#include <numeric>
#include <string>

namespace pmg {

namespace {
constexpr int W = kBinLanes;
constexpr int BB = Bcsr::kBlockSize;

bool same_pattern(const BlockPattern& a, const BlockPattern& b) {
  return a.rows == b.rows && a.cols == b.cols && a.row_ptr == b.row_ptr && a.col_idx == b.col_idx;
}

bool has_diagonal(const BlockPattern& p, index_t I) { return p.find(I, I) >= 0; }

index_t off_diagonal_blocks(const BlockPattern& p, index_t I) {
  return static_cast<index_t>(p.row_ptr[I + 1] - p.row_ptr[I]) - (has_diagonal(p, I) ? 1 : 0);
}
}  // namespace

int BinBcsr::auto_lanes(const BlockPattern& p) {
  if (p.rows == 0) return 1;
  offset_t off = 0;
  for (index_t I = 0; I < p.rows; ++I) off += off_diagonal_blocks(p, I);
  const double mean = static_cast<double>(off) / p.rows;
  int L = 1;
  while (L < W && mean / (2 * L) >= BinBcsrOptions::kMinSteps) L *= 2;
  return L;
}

BinBcsr::BinBcsr(const Bcsr& A, const BinBcsrOptions& options) {
  if (A.block_rows() != A.block_cols()) throw InputError("BIN-BCSR: matrix must be square");
  const BlockPattern& p = A.pattern();
  const int L = options.lanes == 0 ? auto_lanes(p) : options.lanes;
  if (L < 1 || L > W || (L & (L - 1)) != 0)
    throw InputError("BIN-BCSR: lanes must be 0 (automatic) or a power of two from 1 to 32, got " +
                     std::to_string(options.lanes));
  if (options.sort_window < 0)
    throw InputError("BIN-BCSR: sort_window must be 0 (automatic) or positive, got " +
                     std::to_string(options.sort_window));
  const index_t R = W / L;  // block rows per bin
  source_pattern_ = A.shared_pattern();
  source_blocks_ = A.num_blocks();
  block_rows_ = p.rows;
  lanes_ = L;
  // Whole bins per window (rounded up), so that no bin mixes rows of two windows.
  const std::int64_t window = options.sort_window == 0 ? std::int64_t{BinBcsrOptions::kDefaultBins} * R
                                                       : (std::int64_t{options.sort_window} + R - 1) / R * R;
  sort_window_ = options.sort_window == 1 ? 1 : static_cast<index_t>(std::min<std::int64_t>(window, std::max<index_t>(block_rows_, R)));

  // Order: within each window, longest rows first (stable, so equal rows keep their order).
  std::vector<index_t> len(block_rows_);
  for (index_t I = 0; I < block_rows_; ++I) len[I] = off_diagonal_blocks(p, I);
  const index_t nbins = (block_rows_ + R - 1) / R;
  permutation_.assign(static_cast<std::size_t>(nbins) * R, -1);
  std::iota(permutation_.begin(), permutation_.begin() + block_rows_, 0);
  for (std::int64_t w0 = 0; w0 < block_rows_; w0 += sort_window_) {
    const std::int64_t w1 = std::min<std::int64_t>(block_rows_, w0 + sort_window_);
    std::stable_sort(permutation_.begin() + w0, permutation_.begin() + w1,
                     [&](index_t a, index_t b) { return len[a] > len[b]; });
  }

  // Slicing: a bin's width is its longest row's number of steps.
  width_.assign(nbins, 0);
  offset_.assign(nbins + 1, 0);
  for (index_t b = 0; b < nbins; ++b) {
    index_t longest = 0;
    for (index_t r = 0; r < R; ++r) {
      const index_t I = permutation_[b * R + r];
      if (I >= 0) longest = std::max(longest, len[I]);
    }
    width_[b] = (longest + L - 1) / L;
    offset_[b + 1] = offset_[b] + static_cast<std::int64_t>(W) * width_[b];
  }
  columns_.assign(offset_[nbins], -1);
  source_block_.assign(offset_[nbins], -1);
  diag_source_.assign(block_rows_, -1);
  for (index_t b = 0; b < nbins; ++b)
    for (index_t r = 0; r < R; ++r) {
      const index_t I = permutation_[b * R + r];
      if (I < 0) continue;
      index_t k = 0;  // off-diagonal block number within the row
      for (offset_t s = p.row_ptr[I]; s < p.row_ptr[I + 1]; ++s) {
        if (p.col_idx[s] == I) {
          diag_source_[I] = s;
          continue;
        }
        const index_t lane = L * r + k % L, step = k / L;
        const std::int64_t q = offset_[b] + static_cast<std::int64_t>(W) * step + lane;
        columns_[q] = p.col_idx[s];
        source_block_[q] = s;
        ++k;
      }
    }
  values_.assign(BB * static_cast<std::size_t>(offset_[nbins]), 0.0);
  diag_.assign(BB * static_cast<std::size_t>(block_rows_), 0.0);
  // FNV-1a over the layout arrays.
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](std::int64_t v) {
    for (int byte = 0; byte < 8; ++byte, v >>= 8) h = (h ^ static_cast<std::uint64_t>(v & 0xff)) * 1099511628211ull;
  };
  mix(lanes_);
  mix(block_rows_);
  for (index_t v : permutation_) mix(v);
  for (index_t v : width_) mix(v);
  for (index_t v : columns_) mix(v);
  layout_hash_ = h;
  update_values(A);
}

void BinBcsr::update_values(const Bcsr& A) {
  if (!source_pattern_) throw InputError("BIN-BCSR update_values: nothing was sliced (default-constructed)");
  if (A.shared_pattern() != source_pattern_ && !same_pattern(A.pattern(), *source_pattern_))
    throw InputError("BIN-BCSR update_values: the matrix does not have the sliced pattern");
  const double* src = A.values().data();
  const index_t nbins = num_bins();
#pragma omp parallel for schedule(static)
  for (index_t b = 0; b < nbins; ++b)
    for (index_t s = 0; s < width_[b]; ++s)
      for (int lane = 0; lane < W; ++lane) {
        const std::int64_t q = offset_[b] + static_cast<std::int64_t>(W) * s + lane;
        const offset_t from = source_block_[q];
        double* dst = values_.data() + BB * offset_[b] + static_cast<std::int64_t>(BB * W) * s + lane;
        for (int e = 0; e < BB; ++e) dst[e * W] = from >= 0 ? src[BB * from + e] : 0.0;
      }
  for (index_t I = 0; I < block_rows_; ++I) {
    const offset_t from = diag_source_[I];
    for (int e = 0; e < BB; ++e) diag_[BB * I + e] = from >= 0 ? src[BB * from + e] : 0.0;
  }
}

BinBcsrView BinBcsr::view() const {
  BinBcsrView v;
  v.rows = rows();
  v.num_bins = num_bins();
  v.lanes = lanes_;
  v.permutation = permutation_.data();
  v.width = width_.data();
  v.offset = offset_.data();
  v.columns = columns_.data();
  v.values = values_.data();
  v.diag = diag_.data();
  return v;
}

double BinBcsr::padding_ratio() const {
  if (source_blocks_ == 0) return 1.0;
  return static_cast<double>(values_.size() + diag_.size()) / (BB * static_cast<double>(source_blocks_));
}

double BinBcsr::bytes_per_spmv() const {
  return 8.0 * static_cast<double>(values_.size() + diag_.size()) + 4.0 * static_cast<double>(columns_.size()) +
         4.0 * static_cast<double>(permutation_.size()) + 12.0 * static_cast<double>(width_.size()) +
         2.0 * 8.0 * rows();
}

// Per bin: the 32 lanes' partial sums, each in bin_bcsr_lane's order (its diagonal product, then
// its steps in turn) but computed step by step across the lanes, which reads the bin's values in
// storage order; then each row's sum tree and its first lane's result. tests/gpu checks this
// against bin_bcsr_lane bit for bit.
void BinBcsr::multiply(const double* x, double* y) const {
  const int L = lanes_;
  const index_t R = W / L;
  const index_t nbins = num_bins();
#pragma omp parallel for schedule(static)
  for (index_t b = 0; b < nbins; ++b) {
    double p[W][3];
    int row[W];
    for (int lane = 0; lane < W; ++lane) {
      const index_t I = permutation_[b * R + lane / L];
      row[lane] = I;
      p[lane][0] = p[lane][1] = p[lane][2] = 0.0;
      if (I >= 0 && lane % L == 0)
        block3_apply(diag_.data() + BB * static_cast<std::int64_t>(I), x + 3 * static_cast<std::int64_t>(I), p[lane]);
    }
    const std::int64_t q0 = offset_[b];
    for (index_t s = 0; s < width_[b]; ++s) {
      const index_t* cols = columns_.data() + q0 + static_cast<std::int64_t>(W) * s;
      const double* v = values_.data() + BB * q0 + static_cast<std::int64_t>(BB * W) * s;
      for (int lane = 0; lane < W; ++lane) {
        const index_t col = cols[lane];
        if (col < 0) continue;  // padding
        const double* xj = x + 3 * static_cast<std::int64_t>(col);
        const double x0 = xj[0], x1 = xj[1], x2 = xj[2];
        const double* vl = v + lane;
        p[lane][0] += vl[0] * x0 + vl[W] * x1 + vl[2 * W] * x2;
        p[lane][1] += vl[3 * W] * x0 + vl[4 * W] * x1 + vl[5 * W] * x2;
        p[lane][2] += vl[6 * W] * x0 + vl[7 * W] * x1 + vl[8 * W] * x2;
      }
    }
    for (int g = 0; g < W; g += L) {
      if (row[g] < 0) continue;
      bin_bcsr_fold(p + g, L);
      double* yi = y + 3 * static_cast<std::int64_t>(row[g]);
      yi[0] = p[g][0];
      yi[1] = p[g][1];
      yi[2] = p[g][2];
    }
  }
}

void BinBcsr::apply_impl(const Vector& x, Vector& y) const { multiply(x.data(), y.data()); }

}  // namespace pmg
