// pmg/sparse/block3.hpp — the 3x3 block product every block-diagonal (block-Jacobi) operation is
// built on, written once for the CPU kernels and the CUDA kernels (PMG_HOST_DEVICE: __host__
// __device__ under nvcc, inline otherwise).
#pragma once

#if defined(__CUDACC__)
#define PMG_HOST_DEVICE __host__ __device__ __forceinline__
#else
#define PMG_HOST_DEVICE inline
#endif

namespace pmg {

/// z = B r for one 3x3 row-major block B and 3-vectors r and z (z must not alias r); double or
/// float (a float cycle's D⁻¹).
template <typename T>
PMG_HOST_DEVICE void block3_apply(const T* B, const T* r, T* z) {
  z[0] = B[0] * r[0] + B[1] * r[1] + B[2] * r[2];
  z[1] = B[3] * r[0] + B[4] * r[1] + B[5] * r[2];
  z[2] = B[6] * r[0] + B[7] * r[1] + B[8] * r[2];
}

}  // namespace pmg
