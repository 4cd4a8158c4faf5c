// cuBLAS and cuSPARSE on first use (vendor_libraries.hpp).
#include "vendor_libraries.hpp"

#include "pmg/gpu/device.hpp"

#include <dlfcn.h>

#include <mutex>
#include <string>

namespace pmg::gpu::detail {

namespace {

std::string last_error() {
  const char* e = dlerror();
  return e ? e : "unknown reason";
}

/// dlopen by soname, then by the configure-time path; CudaError with both reasons otherwise.
void* open_library(const char* what, const char* soname, const char* path) {
  void* h = dlopen(soname, RTLD_NOW | RTLD_LOCAL);
  if (h) return h;
  const std::string first = last_error();
  h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (h) return h;
  throw CudaError(std::string(what) + " could not be loaded (" + soname + ": " + first + "; " + path + ": " +
                  last_error() + ")");
}

}  // namespace

void* cublas_library() {
  static void* h = open_library("cuBLAS", PMG_CUBLAS_SONAME, PMG_CUBLAS_PATH);
  return h;
}

void* cusparse_library() {
  static void* h = open_library("cuSPARSE", PMG_CUSPARSE_SONAME, PMG_CUSPARSE_PATH);
  return h;
}

void* vendor_symbol(void* library, const char* name) {
  static std::mutex m;  // dlerror's state is per thread, but keep the two calls together
  std::lock_guard<std::mutex> lock(m);
  dlerror();
  void* f = dlsym(library, name);
  if (!f) throw CudaError(std::string("CUDA vendor library: no function ") + name + " (" + last_error() + ")");
  return f;
}

}  // namespace pmg::gpu::detail

namespace pmg::gpu {

void load_vendor_libraries() {
  // Every function the call sites of cusparse.cpp, library_pcg.cpp and cuda_check.hpp resolve.
  for (const char* f : {"cublasCreate_v2", "cublasDestroy_v2", "cublasDdot_v2", "cublasDaxpy_v2", "cublasDgeam"})
    detail::vendor_symbol(detail::cublas_library(), f);
  for (const char* f : {"cusparseCreate", "cusparseDestroy", "cusparseCreateMatDescr", "cusparseDestroyMatDescr",
                        "cusparseSetMatType", "cusparseSetMatIndexBase", "cusparseDbsrmv", "cusparseCreateCsr",
                        "cusparseDestroySpMat", "cusparseCreateDnVec", "cusparseDestroyDnVec", "cusparseSpMV",
                        "cusparseSpMV_bufferSize", "cusparseGetErrorString"})
    detail::vendor_symbol(detail::cusparse_library(), f);
}

}  // namespace pmg::gpu
