// pmg/sparse/bin_bcsr.hpp — BIN-BCSR, the GPU layout of Weber et al. (2013), as a CPU reference.
//
// Scalar rows are grouped into bins of kBinRows = 32 consecutive rows (one warp on the GPU, one
// thread per row). Inside a bin everything is stored column-major, so the 32 rows of a bin read
// consecutive addresses at each step:
//
//   values:  the c-th value (c = 0..2) of the k-th off-diagonal block of scalar row r lives at
//            val_offset[bin] + (3k + c)*32 + (r mod 32)
//   columns: one block-column index per block, shared by the three scalar rows of a block row; a bin
//            holds nbr = (block rows it touches) of them per step k, at
//            col_offset[bin] + k*nbr + (r/3 - first_block_row[bin])
//            (a block row that straddles two bins appears in both).
//   padding: each bin is padded to its longest block row (width[bin] blocks); padding blocks carry
//            column -1 and zero values.
//   diagonal: the diagonal blocks are not in the bins; they are stored separately (9 doubles per
//            block row, row-major), which makes (block-)Jacobi and Gauss–Seidel diagonal solves cheap.
//
// SpMV, one scalar row r:  y_r = D_r x  +  sum_k sum_c values[pos + 32c] * x[3 col + c].
//
// Slicing (the plan) depends only on the BCSR pattern; update_values() refills the values from a
// BCSR matrix with the same pattern through a stored map, without re-slicing or reallocating.
#pragma once

#include "pmg/sparse/bcsr.hpp"

#include <vector>

namespace pmg {

/// A square 3x3-block matrix in the BIN-BCSR layout (see the file comment): the CPU reference of
/// the GPU kernel, sliced once from a Bcsr and refilled with update_values().
class BinBcsr final : public LinearOperator {
 public:
  /// Scalar rows per bin (one GPU warp).
  static constexpr int kBinRows = 32;

  BinBcsr() = default;
  /// Slices the pattern of A (square) and copies its values.
  explicit BinBcsr(const Bcsr& A);

  /// Refills values and diagonal blocks from A, which must have the pattern this was built from.
  void update_values(const Bcsr& A);

  index_t rows() const override { return 3 * block_rows_; }
  index_t cols() const override { return 3 * block_rows_; }
  /// Number of block rows (rows() / 3).
  index_t block_rows() const { return block_rows_; }
  /// Number of bins: rows() / kBinRows, rounded up.
  index_t num_bins() const { return static_cast<index_t>(width_.size()); }

  // Layout arrays (read-only), for uploads to a device and for tests.
  /// Per bin: the most off-diagonal blocks of any block row it touches (rows are padded to it).
  const std::vector<index_t>& width() const { return width_; }
  /// Per bin: the first block row it touches.
  const std::vector<index_t>& first_block_row() const { return first_block_row_; }
  /// Per bin: the number of block rows it touches (nbr in the file comment).
  const std::vector<index_t>& bin_block_rows() const { return bin_block_rows_; }
  /// Per bin, plus one at the end: where the bin's block columns start in columns().
  const std::vector<offset_t>& col_offset() const { return col_offset_; }
  /// Per bin, plus one at the end: where the bin's values start in values().
  const std::vector<offset_t>& val_offset() const { return val_offset_; }
  /// Block-column indices of the off-diagonal blocks, bin by bin (-1: padding).
  const std::vector<index_t>& columns() const { return columns_; }
  /// Off-diagonal values in the bins' column-major layout (zero in padding).
  const std::vector<double>& values() const { return values_; }
  /// The diagonal blocks, 9 doubles per block row, row-major (zero where the source has none).
  const std::vector<double>& diagonal_blocks() const { return diag_; }

  /// Stored values including padding, over the values of the source matrix (>= 1).
  double padding_ratio() const;
  /// Bytes one SpMV reads and writes at least (values, columns, diagonal, x once, y once).
  double bytes_per_spmv() const;

  /// Raw kernel: y[0:rows) = A x (x has cols() entries; x and y must not overlap). OpenMP parallel
  /// over bins.
  void multiply(const double* x, double* y) const;

 private:
  void apply_impl(const Vector& x, Vector& y) const override;

  index_t block_rows_ = 0;
  offset_t source_blocks_ = 0;
  std::shared_ptr<const BlockPattern> source_pattern_;
  std::vector<index_t> width_, first_block_row_, bin_block_rows_;
  std::vector<offset_t> col_offset_, val_offset_;
  std::vector<index_t> columns_;
  std::vector<offset_t> source_block_;  ///< per column slot: block index in the source BCSR, or -1
  std::vector<offset_t> diag_source_;   ///< per block row: diagonal block index in the source, or -1
  std::vector<double> values_, diag_;
};

}  // namespace pmg
