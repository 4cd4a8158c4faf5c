// Private: the BIN-BCSR warp kernel body shared by the SpMV, residual and MCG kernels.
#pragma once

#include "pmg/sparse/bin_bcsr.hpp"

namespace pmg::gpu::detail {

/// Threads a BIN-BCSR kernel is launched with: one warp per bin.
inline long long bin_bcsr_threads(const BinBcsrView& A) {
  return static_cast<long long>(kBinLanes) * A.num_bins;
}

/// (A x)_I for the block row I of this thread's group: every thread of the grid must call it (the
/// xor shuffles take the whole warp; a launch of bin_bcsr_threads(A) threads in blocks of a
/// multiple of 32 gives whole warps). Returns I in the group's first lane, where q holds the
/// three sums, and -1 in every other lane (and for unused slots and warps past the last bin).
/// The sum tree is bin_bcsr_fold's: the result is BinBcsr::multiply's up to FMA contraction.
__device__ __forceinline__ int bin_bcsr_warp(const BinBcsrView& A, const double* __restrict__ x,
                                             double q[3]) {
  const long long g = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
  const int bin = static_cast<int>(g / kBinLanes), lane = static_cast<int>(g % kBinLanes);
  int I = -1;
  q[0] = q[1] = q[2] = 0.0;
  if (bin < A.num_bins) I = bin_bcsr_lane(A, x, bin, lane, q);
  for (int off = A.lanes / 2; off > 0; off /= 2)
    for (int c = 0; c < 3; ++c) q[c] += __shfl_xor_sync(0xffffffffu, q[c], off);
  return lane % A.lanes == 0 ? I : -1;
}

}  // namespace pmg::gpu::detail
