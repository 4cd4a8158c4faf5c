// pmg/sparse/bin_bcsr.hpp — BIN-BCSR, the GPU layout of Weber et al. (2013) with the row sorting
// of SELL-C-σ (Kreutzer, Hager, Wellein, Fehske, Bishop, SIAM J. Sci. Comput. 2014), as a CPU
// reference whose per-lane kernel (bin_bcsr_lane below) is the one the CUDA module runs.
//
// Block rows are served by `lanes` L consecutive threads each (L = 1, 2, 4, …, 32); a bin is one
// warp of kBinLanes = 32 threads, so it holds R = 32/L block rows ("slots"):
//
//   order:    within each window of sort_window consecutive block rows, rows are sorted by their
//             number of off-diagonal blocks, longest first (stable), so the rows sharing a bin have
//             nearly the same length. permutation()[slot] is the block row of a slot (-1 for the
//             unused slots at the end of the last bin). x and y stay in the original numbering.
//   blocks:   lane t of a row's group takes the row's off-diagonal blocks k = t, t + L, t + 2L, …
//             (in BCSR's column order); step s of lane `lane` of bin b is the block slot
//                 q = offset[b] + 32 s + lane,     s = 0 … width[b]-1,
//             with its block column at columns()[q] (-1: padding) and its 3x3 block, row-major,
//             at values()[9 offset[b] + 288 s + 32 e + lane], e = 0 … 8: at each step the 32
//             lanes of a warp read consecutive addresses.
//   width:    width[b] = the most steps any lane of the bin takes, ⌈(longest row of the bin) / L⌉.
//             Padding is what the sorting and the choice of L keep small.
//   diagonal: the diagonal blocks are not in the bins; they are stored apart (9 doubles per block
//             row, row-major, original numbering), which makes (block-)Jacobi and Gauss–Seidel
//             diagonal solves cheap. The first lane of a row's group adds D_I x_I.
//
// SpMV: each lane sums its blocks into three partial sums p (lane t = 0 starting from D_I x_I),
// then the L partial sums of a row are added in a binary tree, as __shfl_xor_sync does on the
// device (bin_bcsr_fold), and the first lane writes y_I. The CPU multiply() runs the same lanes and
// the same tree; host and device differ only where the compilers contract multiply-adds into FMAs
// differently.
//
// The plan (order, lanes, slicing) depends only on the BCSR pattern; update_values() refills the
// values from a BCSR matrix with the same pattern through a stored map, without re-slicing.
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/block3.hpp"

#include <cstdint>
#include <vector>

namespace pmg {

/// How a BinBcsr is laid out; the defaults choose both from the pattern.
struct BinBcsrOptions {
  /// Threads per block row: 1, 2, 4, 8, 16 or 32; 0 chooses the largest L with at least
  /// kMinSteps steps per lane on an average row (BinBcsr::auto_lanes).
  int lanes = 0;
  /// Block rows per sorting window (σ of SELL-C-σ); 1 keeps the original order; 0 chooses
  /// kDefaultBins bins' worth of rows. Other values are rounded up to whole bins (32 / lanes rows),
  /// so that no bin mixes two windows.
  index_t sort_window = 0;
  /// Bins per sorting window when sort_window = 0.
  static constexpr index_t kDefaultBins = 32;
  /// Steps per lane an average row should keep when lanes = 0.
  static constexpr double kMinSteps = 8.0;
};

/// Raw pointers of a BIN-BCSR matrix: what a device kernel receives (and the host kernel reads).
struct BinBcsrView {
  int rows = 0;        ///< scalar rows (3 per block row)
  int num_bins = 0;    ///< warps
  int lanes = 1;       ///< threads per block row
  const int* permutation = nullptr;       ///< per slot: its block row, or -1
  const int* width = nullptr;             ///< per bin: steps
  const std::int64_t* offset = nullptr;   ///< per bin: first block slot
  const int* columns = nullptr;           ///< per block slot: block column, or -1 (padding)
  const double* values = nullptr;         ///< 9 per block slot, in the bins' lane-major layout
  const double* diag = nullptr;           ///< 9 per block row, row-major
};

/// Threads in one bin (one GPU warp).
constexpr int kBinLanes = 32;

/// What lane `lane` of bin `bin` computes: p[0..2] = its share of (A x)_I for its block row I,
/// which it returns (-1 for an unused slot, with p = 0). Lane t = 0 of the row's group includes
/// D_I x_I. The shares of a group's L lanes are added with bin_bcsr_fold (host) or the xor
/// shuffles of the CUDA kernels, in the same tree.
PMG_HOST_DEVICE int bin_bcsr_lane(const BinBcsrView& A, const double* x, int bin, int lane, double p[3]) {
  const int L = A.lanes;
  const int I = A.permutation[bin * (kBinLanes / L) + lane / L];
  p[0] = p[1] = p[2] = 0.0;
  if (I < 0) return -1;
  if (lane % L == 0) block3_apply(A.diag + 9 * static_cast<std::int64_t>(I), x + 3 * static_cast<std::int64_t>(I), p);
  const std::int64_t q0 = A.offset[bin];
  const int* cols = A.columns + q0 + lane;
  const double* v = A.values + 9 * q0 + lane;
  const int width = A.width[bin];
  for (int s = 0; s < width; ++s, cols += kBinLanes, v += 9 * kBinLanes) {
    const int col = *cols;
    if (col < 0) break;  // padding; a lane's padding steps are its last ones
    const double* xj = x + 3 * static_cast<std::int64_t>(col);
    const double x0 = xj[0], x1 = xj[1], x2 = xj[2];
    p[0] += v[0] * x0 + v[kBinLanes] * x1 + v[2 * kBinLanes] * x2;
    p[1] += v[3 * kBinLanes] * x0 + v[4 * kBinLanes] * x1 + v[5 * kBinLanes] * x2;
    p[2] += v[6 * kBinLanes] * x0 + v[7 * kBinLanes] * x1 + v[8 * kBinLanes] * x2;
  }
  return I;
}

/// The sum tree of one row's L partial sums, p[0] += p[off] for off = L/2, L/4, …, 1, in place:
/// lane 0's value after `v += __shfl_xor_sync(mask, v, off)` for the same offsets.
PMG_HOST_DEVICE void bin_bcsr_fold(double (*p)[3], int lanes) {
  for (int off = lanes / 2; off > 0; off /= 2)
    for (int t = 0; t < off; ++t)
      for (int c = 0; c < 3; ++c) p[t][c] += p[t + off][c];
}

/// A square 3x3-block matrix in the BIN-BCSR layout (see the file comment): the CPU reference of
/// the GPU kernel, sliced once from a Bcsr and refilled with update_values().
class BinBcsr final : public LinearOperator {
 public:
  /// This matrix (LinearOperator's capability query).
  const BinBcsr* bin_bcsr_matrix() const override { return this; }
  /// Threads per bin (one GPU warp).
  static constexpr int kBinLanes = pmg::kBinLanes;

  BinBcsr() = default;
  /// Orders and slices the pattern of A (square) and copies its values. Throws InputError for a
  /// matrix that is not square or options out of range.
  explicit BinBcsr(const Bcsr& A, const BinBcsrOptions& options = {});

  /// Refills values and diagonal blocks from A, which must have the pattern this was built from
  /// (InputError otherwise, or when nothing was built).
  void update_values(const Bcsr& A);

  index_t rows() const override { return 3 * block_rows_; }
  index_t cols() const override { return 3 * block_rows_; }
  /// Number of block rows (rows() / 3).
  index_t block_rows() const { return block_rows_; }
  /// Number of bins (warps): block_rows() / (32 / lanes()), rounded up.
  index_t num_bins() const { return static_cast<index_t>(width_.size()); }
  /// Threads per block row.
  int lanes() const { return lanes_; }
  /// Block rows per sorting window (1: unsorted).
  index_t sort_window() const { return sort_window_; }
  /// The lanes chosen for `options.lanes = 0`: the largest power of two L ≤ 32 with
  /// (mean off-diagonal blocks per row) / L ≥ kMinSteps, at least 1.
  static int auto_lanes(const BlockPattern& p);

  // Layout arrays (read-only), for uploads to a device and for tests.
  /// Per slot (num_bins() · 32/lanes()): its block row, or -1.
  const std::vector<index_t>& permutation() const { return permutation_; }
  /// Per bin: steps per lane.
  const std::vector<index_t>& width() const { return width_; }
  /// Per bin, plus one at the end: its first block slot (columns()[q], values()[9q …]).
  const std::vector<std::int64_t>& offset() const { return offset_; }
  /// Block columns per block slot (-1: padding).
  const std::vector<index_t>& columns() const { return columns_; }
  /// Off-diagonal blocks in the bins' lane-major layout (zero in padding).
  const std::vector<double>& values() const { return values_; }
  /// The diagonal blocks, 9 doubles per block row, row-major (zero where the source has none).
  const std::vector<double>& diagonal_blocks() const { return diag_; }
  /// The arrays as the plain struct bin_bcsr_lane takes (pointers into this object).
  BinBcsrView view() const;
  /// A 64-bit hash of the layout (lanes, permutation, widths, columns): equal for the slicing of
  /// one pattern with one set of options, so a device copy can check that new values fit it.
  std::uint64_t layout_hash() const { return layout_hash_; }

  /// Stored values including padding, over the values of the source matrix (>= 1).
  double padding_ratio() const;
  /// Bytes one SpMV moves at least: values and columns with padding, diagonal blocks, the
  /// permutation, widths and offsets, x once and y once.
  double bytes_per_spmv() const;

  /// Raw kernel: y[0:rows) = A x (x has cols() entries; x and y must not overlap). OpenMP parallel
  /// over bins; the same lanes, per-lane order and sum tree as the device.
  void multiply(const double* x, double* y) const;

 private:
  void apply_impl(const Vector& x, Vector& y) const override;

  index_t block_rows_ = 0;
  int lanes_ = 1;
  index_t sort_window_ = 1;
  offset_t source_blocks_ = 0;
  std::shared_ptr<const BlockPattern> source_pattern_;
  std::vector<index_t> permutation_, width_, columns_;
  std::vector<std::int64_t> offset_;
  std::vector<offset_t> source_block_;  ///< per block slot: block index in the source BCSR, or -1
  std::vector<offset_t> diag_source_;   ///< per block row: diagonal block index in the source, or -1
  std::vector<double> values_, diag_;
  std::uint64_t layout_hash_ = 0;
};

}  // namespace pmg
