// Private: block sums finished by the last block to arrive (the "threadfence reduction" of the
// CUDA samples), so a kernel can end with a global sum and act on it without another launch.
// Partial sums are added in block order: the result does not depend on scheduling.
#pragma once

#include "cuda_check.hpp"

#include <cub/block/block_reduce.cuh>

namespace pmg::gpu::detail {

/// Sums v[0..N) over the whole grid. partials: N * gridDim.x doubles of scratch; counter: an
/// unsigned int that is 0 before the launch (and is 0 again after it). Returns true in the last
/// block to finish, where thread 0 holds the grid sums in total[].
template <int N>
__device__ bool grid_sum(const double (&v)[N], double* partials, unsigned int* counter,
                         double (&total)[N]) {
  using BlockReduce = cub::BlockReduce<double, kThreads>;
  __shared__ typename BlockReduce::TempStorage tmp;
  __shared__ bool last;
  const unsigned G = gridDim.x;
  for (int i = 0; i < N; ++i) {
    const double s = BlockReduce(tmp).Sum(v[i]);
    __syncthreads();
    if (threadIdx.x == 0) partials[i * G + blockIdx.x] = s;
  }
  if (threadIdx.x == 0) {
    __threadfence();  // the partials are visible before the ticket is taken
    last = atomicInc(counter, G) == G - 1;
  }
  __syncthreads();
  if (!last) return false;
  for (int i = 0; i < N; ++i) {
    double acc = 0.0;
    for (unsigned j = threadIdx.x; j < G; j += blockDim.x) acc += __ldcg(partials + i * G + j);
    const double s = BlockReduce(tmp).Sum(acc);
    __syncthreads();
    if (threadIdx.x == 0) total[i] = s;
  }
  if (threadIdx.x == 0) *counter = 0;
  return true;
}

}  // namespace pmg::gpu::detail
