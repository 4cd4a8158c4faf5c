#include "cuda_check.hpp"
#include "pmg/gpu/matrices.hpp"

namespace pmg::gpu {

namespace {

using detail::BinBcsrView;
using detail::CsrView;

// y = A x, one thread per scalar row. Bytes: values + columns + diagonal once, x (mostly cached),
// y once.
__global__ void bin_bcsr_spmv_kernel(BinBcsrView A, const double* __restrict__ x,
                                     double* __restrict__ y) {
  const int row = blockIdx.x * blockDim.x + threadIdx.x;
  if (row < A.rows) y[row] = detail::bin_bcsr_row(A, x, row);
}

// r = b - A x in one pass.
__global__ void bin_bcsr_residual_kernel(BinBcsrView A, const double* __restrict__ b,
                                         const double* __restrict__ x, double* __restrict__ r) {
  const int row = blockIdx.x * blockDim.x + threadIdx.x;
  if (row < A.rows) r[row] = b[row] - detail::bin_bcsr_row(A, x, row);
}

__global__ void bcsr_spmv_kernel(CsrView A, const double* __restrict__ x, double* __restrict__ y) {
  const int row = blockIdx.x * blockDim.x + threadIdx.x;
  if (row < 3 * A.rows) y[row] = detail::bcsr_row(A, x, row);
}

void check_vectors(index_t n, const DeviceVector& x, DeviceVector& y, const char* what) {
  if (x.size() != static_cast<std::size_t>(n))
    throw InputError(std::string(what) + ": x has " + std::to_string(x.size()) + " entries, the matrix " +
                     std::to_string(n) + " columns");
  y.resize(static_cast<std::size_t>(n));
}

}  // namespace

// ---- DeviceBinBcsr -----------------------------------------------------------------------------

DeviceBinBcsr::DeviceBinBcsr(const BinBcsr& A)
    : rows_(A.rows()), num_values_(A.values().size()), num_columns_(A.columns().size()),
      bytes_(A.bytes_per_spmv()), width_(A.width()), first_block_row_(A.first_block_row()),
      bin_block_rows_(A.bin_block_rows()), columns_(A.columns()), col_offset_(A.col_offset()),
      val_offset_(A.val_offset()), values_(A.values()), diag_(A.diagonal_blocks()) {}

void DeviceBinBcsr::update_values(const BinBcsr& A) {
  if (A.rows() != rows_ || A.values().size() != num_values_ || A.columns().size() != num_columns_)
    throw InputError("DeviceBinBcsr::update_values: the matrix does not have the uploaded layout");
  values_.upload(A.values());
  diag_.upload(A.diagonal_blocks());
}

detail::BinBcsrView DeviceBinBcsr::view() const {
  detail::BinBcsrView v;
  v.rows = rows_;
  v.width = width_.data();
  v.first_block_row = first_block_row_.data();
  v.bin_block_rows = bin_block_rows_.data();
  v.col_offset = col_offset_.data();
  v.val_offset = val_offset_.data();
  v.columns = columns_.data();
  v.values = values_.data();
  v.diag = diag_.data();
  return v;
}

void DeviceBinBcsr::multiply(const DeviceVector& x, DeviceVector& y) const {
  check_vectors(rows_, x, y, "DeviceBinBcsr::multiply");
  if (rows_ == 0) return;
  bin_bcsr_spmv_kernel<<<detail::blocks_for(rows_), detail::kThreads>>>(view(), x.data(), y.data());
  PMG_LAUNCHED("bin_bcsr_spmv_kernel");
}

void DeviceBinBcsr::residual(const DeviceVector& b, const DeviceVector& x, DeviceVector& r) const {
  check_vectors(rows_, x, r, "DeviceBinBcsr::residual");
  if (b.size() != x.size()) throw InputError("DeviceBinBcsr::residual: b and x differ in size");
  if (rows_ == 0) return;
  bin_bcsr_residual_kernel<<<detail::blocks_for(rows_), detail::kThreads>>>(view(), b.data(), x.data(),
                                                                             r.data());
  PMG_LAUNCHED("bin_bcsr_residual_kernel");
}

// ---- DeviceCsr, DeviceBcsr ----------------------------------------------------------------------

DeviceCsr::DeviceCsr(const CsrPattern& pattern, const std::vector<double>& values)
    : rows_(pattern.rows), cols_(pattern.cols), row_ptr_(pattern.row_ptr), col_idx_(pattern.col_idx),
      values_(values) {}

void DeviceCsr::update_values(const std::vector<double>& values) {
  if (values.size() != values_.size())
    throw InputError("DeviceCsr/DeviceBcsr::update_values: the matrix does not have the uploaded pattern");
  values_.upload(values);
}

detail::CsrView DeviceCsr::view() const {
  return {rows_, row_ptr_.data(), col_idx_.data(), values_.data()};
}

DeviceBcsr::DeviceBcsr(const Bcsr& A) : blocks_(A.pattern(), A.values()) {
  if (A.rows() != A.cols()) throw InputError("DeviceBcsr: matrix must be square");
}

void DeviceBcsr::multiply(const DeviceVector& x, DeviceVector& y) const {
  const index_t n = rows();
  check_vectors(n, x, y, "DeviceBcsr::multiply");
  if (n == 0) return;
  bcsr_spmv_kernel<<<detail::blocks_for(n), detail::kThreads>>>(view(), x.data(), y.data());
  PMG_LAUNCHED("bcsr_spmv_kernel");
}

}  // namespace pmg::gpu
