#include "bin_bcsr.cuh"
#include "cuda_check.hpp"
#include "pmg/gpu/matrices.hpp"

namespace pmg::gpu {

namespace {

using detail::BinBcsrView;
using detail::CsrView;

// y = A x, one warp per bin, `lanes` threads per block row. Bytes: values, columns (padding
// included), diagonal blocks, permutation once, x (mostly cached), y once.
__global__ void bin_bcsr_spmv_kernel(BinBcsrView A, const double* __restrict__ x,
                                     double* __restrict__ y) {
  double q[3];
  const int I = detail::bin_bcsr_warp(A, x, q);
  if (I >= 0)
    for (int c = 0; c < 3; ++c) y[3LL * I + c] = q[c];
}

// r = b - A x in one pass.
__global__ void bin_bcsr_residual_kernel(BinBcsrView A, const double* __restrict__ b,
                                         const double* __restrict__ x, double* __restrict__ r) {
  double q[3];
  const int I = detail::bin_bcsr_warp(A, x, q);
  if (I >= 0)
    for (int c = 0; c < 3; ++c) r[3LL * I + c] = b[3LL * I + c] - q[c];
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
    : rows_(A.rows()), num_bins_(A.num_bins()), lanes_(A.lanes()), num_values_(A.values().size()),
      num_columns_(A.columns().size()), layout_hash_(A.layout_hash()), bytes_(A.bytes_per_spmv()),
      permutation_(A.permutation()),
      width_(A.width()), columns_(A.columns()), offset_(A.offset()), values_(A.values()),
      diag_(A.diagonal_blocks()) {}

void DeviceBinBcsr::update_values(const BinBcsr& A) {
  if (A.rows() != rows_ || A.lanes() != lanes_ || A.num_bins() != num_bins_ ||
      A.values().size() != num_values_ || A.columns().size() != num_columns_ || A.layout_hash() != layout_hash_)
    throw InputError("DeviceBinBcsr::update_values: the matrix does not have the uploaded layout");
  values_.upload(A.values());
  diag_.upload(A.diagonal_blocks());
}

detail::BinBcsrView DeviceBinBcsr::view() const {
  detail::BinBcsrView v;
  v.rows = rows_;
  v.num_bins = num_bins_;
  v.lanes = lanes_;
  v.permutation = permutation_.data();
  v.width = width_.data();
  v.offset = offset_.data();
  v.columns = columns_.data();
  v.values = values_.data();
  v.diag = diag_.data();
  return v;
}

long long DeviceBinBcsr::threads() const { return static_cast<long long>(kBinLanes) * num_bins_; }

void DeviceBinBcsr::multiply(const DeviceVector& x, DeviceVector& y) const {
  check_vectors(rows_, x, y, "DeviceBinBcsr::multiply");
  if (rows_ == 0) return;
  bin_bcsr_spmv_kernel<<<detail::blocks_for(threads()), detail::kThreads>>>(view(), x.data(), y.data());
  PMG_LAUNCHED("bin_bcsr_spmv_kernel");
}

void DeviceBinBcsr::residual(const DeviceVector& b, const DeviceVector& x, DeviceVector& r) const {
  check_vectors(rows_, x, r, "DeviceBinBcsr::residual");
  if (b.size() != x.size()) throw InputError("DeviceBinBcsr::residual: b and x differ in size");
  if (rows_ == 0) return;
  bin_bcsr_residual_kernel<<<detail::blocks_for(threads()), detail::kThreads>>>(view(), b.data(),
                                                                                x.data(), r.data());
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
