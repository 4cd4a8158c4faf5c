// pmg/gpu/matrices.hpp — sparse matrices in device memory and their SpMV kernels.
//
//   DeviceBinBcsr  BIN-BCSR (pmg/sparse/bin_bcsr.hpp): rows sorted within windows, one warp per
//                  bin, `lanes` threads per block row reading consecutive addresses, their sums
//                  added by xor shuffles. The layout (plan) is uploaded once;
//                  update_values() re-uploads only values and diagonal blocks.
//   DeviceBcsr     plain 3x3-block CSR, one thread per scalar row (the straightforward port).
//   CusparseBsr    the vendor baseline: cusparseDbsrmv on the same BCSR (block size 3, row-major).
//   CusparseCsr    the vendor baseline on the scalar CSR: cusparseSpMV (generic API).
// Every multiply() runs on the default stream and returns without waiting.
#pragma once

#include "pmg/gpu/detail/row_kernels.hpp"
#include "pmg/gpu/device.hpp"
#include "pmg/sparse/bin_bcsr.hpp"

#include <memory>

namespace pmg::gpu {

/// A BinBcsr matrix in device memory with its SpMV and residual kernels (see the file comment).
class DeviceBinBcsr {
 public:
  /// Uploads the layout and the values of A.
  explicit DeviceBinBcsr(const BinBcsr& A);
  /// Re-uploads values and diagonal blocks of A, which must be the host matrix this was built
  /// from or one with the same layout (BinBcsr::update_values keeps the layout; checked by
  /// BinBcsr::layout_hash(), InputError otherwise).
  void update_values(const BinBcsr& A);

  /// Number of scalar rows (= columns: the matrix is square).
  index_t rows() const { return rows_; }
  /// y = A x
  void multiply(const DeviceVector& x, DeviceVector& y) const;
  /// r = b - A x (one pass)
  void residual(const DeviceVector& b, const DeviceVector& x, DeviceVector& r) const;
  /// Bytes one SpMV moves at least (the host matrix's count).
  double bytes_per_spmv() const { return bytes_; }
  /// Threads its kernels run: one warp per bin.
  long long threads() const;
  /// The device arrays as the plain struct the library's kernels take (pointers into this object:
  /// valid while it lives).
  detail::BinBcsrView view() const;

 private:
  index_t rows_ = 0, num_bins_ = 0;
  int lanes_ = 1;
  std::size_t num_values_ = 0, num_columns_ = 0;
  std::uint64_t layout_hash_ = 0;  ///< BinBcsr::layout_hash() of the uploaded layout
  double bytes_ = 0;
  DeviceArray<int> permutation_, width_, columns_;
  DeviceArray<std::int64_t> offset_;
  DeviceArray<double> values_, diag_;
};

/// CSR arrays on the device: a scalar CSR matrix (transfer operators), or with 9 values per entry
/// the block pattern and 3x3 blocks of a BCSR matrix.
class DeviceCsr {
 public:
  /// Uploads a scalar CSR matrix. Throws CudaError on failure.
  explicit DeviceCsr(const Csr& A) : DeviceCsr(A.pattern(), A.values()) {}
  /// Uploads a pattern and its values (one per entry, or 9 per entry for 3x3 blocks). Throws
  /// CudaError on failure.
  DeviceCsr(const CsrPattern& pattern, const std::vector<double>& values);
  /// New values on the same pattern (same count).
  void update_values(const std::vector<double>& values);
  /// Number of (block) rows of the pattern.
  index_t rows() const { return rows_; }
  /// Number of (block) columns of the pattern.
  index_t cols() const { return cols_; }
  /// Bytes of values, column indices and row pointers.
  double bytes() const { return 8.0 * values_.size() + 4.0 * col_idx_.size() + 8.0 * row_ptr_.size(); }
  /// The device arrays as the plain struct the library's kernels take (pointers into this object:
  /// valid while it lives).
  detail::CsrView view() const;

 private:
  index_t rows_ = 0, cols_ = 0;
  DeviceArray<std::int64_t> row_ptr_;
  DeviceArray<int> col_idx_;
  DeviceArray<double> values_;
};

/// A Bcsr matrix in device memory with a plain SpMV kernel, one thread per scalar row (see the
/// file comment).
class DeviceBcsr {
 public:
  /// Uploads A's block pattern and values. Throws InputError when A is not square.
  explicit DeviceBcsr(const Bcsr& A);
  /// Re-uploads A's values; A must have the uploaded pattern (InputError when the block count
  /// differs).
  void update_values(const Bcsr& A) { blocks_.update_values(A.values()); }
  /// Number of scalar rows (= columns).
  index_t rows() const { return 3 * blocks_.rows(); }
  /// y = A x (y resized); x must have rows() entries (InputError otherwise).
  void multiply(const DeviceVector& x, DeviceVector& y) const;
  /// Values, columns, row pointers, x once and y once.
  double bytes_per_spmv() const { return blocks_.bytes() + 16.0 * rows(); }
  /// The block arrays as the plain struct the library's kernels take (valid while this lives).
  detail::CsrView view() const { return blocks_.view(); }

 private:
  DeviceCsr blocks_;  ///< block rows, one column per block, 9 values per block
};

/// cuSPARSE's BSR SpMV (cusparseDbsrmv, 3x3 row-major blocks) on a copy of A.
class CusparseBsr {
 public:
  /// Uploads A and creates the cuSPARSE handle. Throws InputError when A is not square or has
  /// 2^31 blocks or more, CudaError when a CUDA or cuSPARSE call fails.
  explicit CusparseBsr(const Bcsr& A);
  ~CusparseBsr();
  CusparseBsr(const CusparseBsr&) = delete;
  CusparseBsr& operator=(const CusparseBsr&) = delete;
  /// Re-uploads A's values; A must have the uploaded pattern (InputError otherwise).
  void update_values(const Bcsr& A);
  /// Number of scalar rows (= columns).
  index_t rows() const { return 3 * block_rows_; }
  /// y = A x
  void multiply(const DeviceVector& x, DeviceVector& y) const;
  /// Values, 32-bit columns and row pointers, x once and y once.
  double bytes_per_spmv() const;

 private:
  index_t block_rows_ = 0, num_blocks_ = 0;
  void* handle_ = nullptr;  ///< cusparseHandle_t
  void* descr_ = nullptr;   ///< cusparseMatDescr_t
  DeviceArray<int> row_ptr_, col_idx_;
  DeviceArray<double> values_;
};

/// cuSPARSE's generic SpMV (cusparseSpMV, CSR, default algorithm) on a copy of A.
class CusparseCsr {
 public:
  /// Uploads A and creates the cuSPARSE handle and descriptor. Throws InputError when A has 2^31
  /// entries or more, CudaError when a CUDA or cuSPARSE call fails.
  explicit CusparseCsr(const Csr& A);
  ~CusparseCsr();
  CusparseCsr(const CusparseCsr&) = delete;
  CusparseCsr& operator=(const CusparseCsr&) = delete;
  /// Number of rows.
  index_t rows() const { return rows_; }
  /// y = A x
  void multiply(const DeviceVector& x, DeviceVector& y) const;
  /// Values and 32-bit columns (12 bytes per entry), row pointers, x once and y once.
  double bytes_per_spmv() const;

 private:
  index_t rows_ = 0, cols_ = 0;
  std::int64_t nnz_ = 0;
  void* handle_ = nullptr;  ///< cusparseHandle_t
  void* mat_ = nullptr;     ///< cusparseSpMatDescr_t
  DeviceArray<int> row_ptr_, col_idx_;
  DeviceArray<double> values_;
  mutable DeviceArray<char> buffer_;
};

}  // namespace pmg::gpu
