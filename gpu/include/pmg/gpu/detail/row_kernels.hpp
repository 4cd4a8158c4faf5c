// pmg/gpu/detail/row_kernels.hpp — what one GPU thread computes, as plain functions that compile
// for the host as well (PMG_HD). The CUDA kernels call them per thread; tests/gpu calls them in a
// loop on the CPU and compares with the host formats (Bcsr, BinBcsr, BlockTransfer), so the
// indexing of every kernel is checked on machines without a GPU.
//
// Layouts are those of pmg/sparse/bin_bcsr.hpp and bcsr.hpp (index_t = int32, offset_t = int64).
#pragma once

#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/block3.hpp"

#include <cstdint>

#define PMG_HD PMG_HOST_DEVICE  // pmg/sparse/block3.hpp: __host__ __device__ under nvcc

namespace pmg::gpu::detail {

// BIN-BCSR's per-lane kernel is pmg::bin_bcsr_lane (pmg/sparse/bin_bcsr.hpp), shared with the
// host format; the device adds the xor-shuffle sum tree (gpu/src/bin_bcsr.cuh).
using pmg::BinBcsrView;

/// Raw pointers of a BCSR (3x3) or scalar CSR matrix.
struct CsrView {
  int rows = 0;  ///< block rows for BCSR, rows for CSR
  const std::int64_t* row_ptr = nullptr;
  const int* col_idx = nullptr;
  const double* values = nullptr;
};

/// (A x)_row of a 3x3-block BCSR matrix, one thread per scalar row (the plain GPU port).
PMG_HD double bcsr_row(const CsrView& A, const double* x, int row) {
  const int I = row / 3, c = row % 3;
  double sum = 0.0;
  for (std::int64_t k = A.row_ptr[I]; k < A.row_ptr[I + 1]; ++k) {
    const double* v = A.values + 9 * k + 3 * c;
    const double* xj = x + 3 * static_cast<std::int64_t>(A.col_idx[k]);
    sum += v[0] * xj[0] + v[1] * xj[1] + v[2] * xj[2];
  }
  return sum;
}

/// y_i = Σ_k T_ik x_k for the three components of node i: a scalar CSR transfer T (prolongation
/// P or restriction R) acting as T ⊗ I₃ on interleaved vectors. add: y_i += instead of =.
PMG_HD void transfer_row(const CsrView& T, const double* x, double* y, int i, bool add) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0;
  for (std::int64_t k = T.row_ptr[i]; k < T.row_ptr[i + 1]; ++k) {
    const double t = T.values[k];
    const double* xj = x + 3 * static_cast<std::int64_t>(T.col_idx[k]);
    s0 += t * xj[0];
    s1 += t * xj[1];
    s2 += t * xj[2];
  }
  double* yi = y + 3 * static_cast<std::int64_t>(i);
  if (add) {
    yi[0] += s0;
    yi[1] += s1;
    yi[2] += s2;
  } else {
    yi[0] = s0;
    yi[1] = s1;
    yi[2] = s2;
  }
}

/// One Chebyshev step on block row I (tests/gpu checks it against mg::Chebyshev):
///   d_I = c1 d_I + c2 D_I⁻¹ r_I ;  x_I += w d_I    (c1 = 0: d is not read, may be uninitialised;
///   w: Lottes' weight of the optimised fourth kind, 1 otherwise)
PMG_HD void chebyshev_block(const double* inv_diag, const double* r, double* d, double* x, int I,
                            double c1, double c2, double w = 1.0) {
  const std::int64_t o = 3 * static_cast<std::int64_t>(I);
  double z[3];
  block3_apply(inv_diag + 9 * static_cast<std::int64_t>(I), r + o, z);
  for (int c = 0; c < 3; ++c) {
    d[o + c] = c1 == 0.0 ? c2 * z[c] : c1 * d[o + c] + c2 * z[c];
    x[o + c] += w == 1.0 ? d[o + c] : w * d[o + c];
  }
}

}  // namespace pmg::gpu::detail
