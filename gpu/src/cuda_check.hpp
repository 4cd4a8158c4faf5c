// Private: turns CUDA, cuSPARSE and cuBLAS status codes into pmg::gpu::CudaError.
#pragma once

#include "pmg/gpu/device.hpp"
#include "vendor_libraries.hpp"

#include <cublas_v2.h>
#include <cuda_runtime.h>
#include <cusparse.h>

#include <string>

namespace pmg::gpu::detail {

inline std::string where(const char* call, const char* file, int line) {
  return std::string(call) + " (" + file + ":" + std::to_string(line) + ")";
}
inline void check_cuda(cudaError_t e, const char* call, const char* file, int line) {
  if (e != cudaSuccess)
    throw CudaError("CUDA error in " + where(call, file, line) + ": " + cudaGetErrorString(e));
}
inline void check_cusparse(cusparseStatus_t e, const char* call, const char* file, int line) {
  if (e != CUSPARSE_STATUS_SUCCESS)
    throw CudaError("cuSPARSE error in " + where(call, file, line) + ": " + PMG_VENDOR(cusparse, cusparseGetErrorString)(e));
}
inline void check_cublas(cublasStatus_t e, const char* call, const char* file, int line) {
  if (e != CUBLAS_STATUS_SUCCESS)
    throw CudaError("cuBLAS error in " + where(call, file, line) + ": status " + std::to_string(e));
}

/// Threads per block of the element-wise and row kernels.
constexpr int kThreads = 256;
inline unsigned blocks_for(long long n) {
  return static_cast<unsigned>((n + kThreads - 1) / kThreads);
}

}  // namespace pmg::gpu::detail

#define PMG_CUDA(call) ::pmg::gpu::detail::check_cuda((call), #call, __FILE__, __LINE__)
#define PMG_CUSPARSE(call) ::pmg::gpu::detail::check_cusparse((call), #call, __FILE__, __LINE__)
#define PMG_CUBLAS(call) ::pmg::gpu::detail::check_cublas((call), #call, __FILE__, __LINE__)
/// After a kernel launch: reports a bad configuration at once (execution errors surface at the
/// next synchronising call).
#define PMG_LAUNCHED(name) ::pmg::gpu::detail::check_cuda(cudaGetLastError(), name, __FILE__, __LINE__)
