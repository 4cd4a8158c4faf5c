// pmg/sparse/bcsr.hpp — block compressed sparse row with dense 3x3 blocks (elasticity: one block per
// pair of coupled nodes, three displacement components each).
//
// Block k occupies values[9k .. 9k+9), row-major inside the block. One column index per block
// cuts index traffic to 4 bytes per 9 values: SpMV moves ~8.4 bytes per scalar nonzero instead of
// CSR's 12, which is where its speed over scalar CSR comes from.
#pragma once

#include "pmg/sparse/csr.hpp"

#include <Eigen/Dense>

#include <memory>
#include <vector>

namespace pmg {

/// A dense 3x3 block, row-major like the blocks stored in Bcsr::values().
using Block3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

/// One 3x3 block of a block matrix under construction (Bcsr::from_block_triplets()).
struct BlockTriplet {
  index_t row;  ///< block row
  index_t col;  ///< block column
  Block3 value;  ///< the block's 3x3 values
};

/// Pattern of a block matrix: the same arrays as CsrPattern, counted in blocks.
using BlockPattern = CsrPattern;

/// A matrix of dense 3x3 blocks in block CSR (see the file comment); the pattern is shared and
/// immutable, the values are updated in place.
class Bcsr final : public LinearOperator {
 public:
  /// This matrix (LinearOperator's capability query).
  const Bcsr* bcsr_matrix() const override { return this; }
  /// Rows (and columns) of one block.
  static constexpr int kBlock = 3;
  /// Values per block.
  static constexpr int kBlockSize = kBlock * kBlock;

  /// The empty 0x0 matrix.
  Bcsr() : pattern_(std::make_shared<BlockPattern>()) {}
  /// Shares `pattern` (validated, counted in blocks) and takes the values, 9 per block in pattern
  /// order. Throws InputError for a null or inconsistent pattern or a wrong number of values.
  Bcsr(std::shared_ptr<const BlockPattern> pattern, std::vector<double> values);

  /// Duplicates are summed.
  static Bcsr from_block_triplets(index_t block_rows, index_t block_cols,
                                  const std::vector<BlockTriplet>& triplets);
  /// Every 3x3 block of A holding at least one pattern entry becomes a stored block (missing
  /// entries of such a block are stored zeros). A's sizes must be multiples of 3.
  static Bcsr from_csr(const Csr& A);
  /// Scalar CSR with all 9 entries of every block (explicit zeros kept).
  Csr to_csr() const;
  /// Writes this matrix's values into `out`, a matrix made by to_csr() from a Bcsr of the same
  /// pattern: no pattern is built (the per-step refresh of a scalar copy). Throws InputError when
  /// out's size or number of entries does not match.
  void copy_values_to(Csr& out) const;

  index_t rows() const override { return kBlock * pattern_->rows; }
  index_t cols() const override { return kBlock * pattern_->cols; }
  /// Number of block rows (rows() / 3).
  index_t block_rows() const { return pattern_->rows; }
  /// Number of block columns (cols() / 3).
  index_t block_cols() const { return pattern_->cols; }
  /// Number of stored blocks.
  offset_t num_blocks() const { return pattern_->nnz(); }
  /// The least bytes one SpMV moves: 9 values and a 4-byte block column per block, 8-byte row
  /// pointers, x and y once (the yardstick of the formats' and kernels' bandwidth figures).
  double bytes_per_spmv() const {
    return 76.0 * static_cast<double>(num_blocks()) + 8.0 * (block_rows() + 1.0) + 16.0 * rows();
  }

  /// The block pattern (row pointers and column indices counted in blocks).
  const BlockPattern& pattern() const { return *pattern_; }
  /// The pattern as the shared pointer other matrices of the same pattern can share.
  const std::shared_ptr<const BlockPattern>& shared_pattern() const { return pattern_; }
  /// Values, 9 per block (row-major) in pattern order.
  const std::vector<double>& values() const { return values_; }
  /// Mutable values in pattern order: write new values in place (the pattern stays).
  std::vector<double>& values() { return values_; }

  /// Block k (0 <= k < num_blocks(), unchecked) as a writable 3x3 view into values().
  Eigen::Map<Block3> block(offset_t k) { return Eigen::Map<Block3>(values_.data() + kBlockSize * k); }
  /// Block k (0 <= k < num_blocks(), unchecked) as a read-only 3x3 view into values().
  Eigen::Map<const Block3> block(offset_t k) const {
    return Eigen::Map<const Block3>(values_.data() + kBlockSize * k);
  }
  /// Position of block (I, J), or -1. Use it once to build an assembly map, then write values().
  offset_t find_block(index_t I, index_t J) const { return pattern_->find(I, J); }

  /// Overwrites the values from a scalar matrix whose entries all lie in stored blocks.
  void set_values(const Csr& A);

  /// Raw kernel: y = A x. OpenMP parallel over block rows.
  void multiply(const double* x, double* y) const;
  /// Diagonal blocks (zero where a block row has none), 9 doubles each.
  std::vector<double> diagonal_blocks() const;
  /// The scalar main diagonal (the diagonals of the diagonal blocks; zero where there is none).
  Vector diagonal() const;

 private:
  void apply_impl(const Vector& x, Vector& y) const override;
  double apply_dot_impl(const Vector& x, Vector& y) const override;
  void residual_impl(const Vector& b, const Vector& x, Vector& r) const override;

  std::shared_ptr<const BlockPattern> pattern_;
  std::vector<double> values_;
};

}  // namespace pmg
