// Private: cuBLAS and cuSPARSE loaded on first use (dlopen) instead of at start-up. The two vendor
// libraries serve only the baselines (CusparseBsr, CusparseCsr, LibraryPcgSolver), yet linked
// directly their loading — cuBLAS pulls in cuBLASLt, cuSPARSE nvJitLink — maps and initialises
// about 170 MB of every process that links pmg::gpu, the CPU-only runs and each MPI rank included.
//
//   PMG_CUSPARSE(PMG_VENDOR(cusparse, cusparseCreate)(&handle));
//
// PMG_VENDOR(lib, fn) is fn's address in the library, resolved once per call site; the library is
// opened on the first use of any of its functions: by its soname (found through the loader's
// paths and pmg::gpu's run path), else at the path found at configure time. A library that cannot
// be opened, or lacks the function, is a CudaError naming it.
#pragma once

namespace pmg::gpu::detail {

/// The cuBLAS library's handle, opened on the first call (CudaError when it cannot be).
void* cublas_library();
/// The cuSPARSE library's handle, opened on the first call (CudaError when it cannot be).
void* cusparse_library();
/// The address of `name` in `library` (CudaError naming both when it is missing).
void* vendor_symbol(void* library, const char* name);

/// `name` in `library` as a pointer of F, the type of the function the vendor header declares.
template <class F>
F vendor_function(void* library, const char* name) {
  return reinterpret_cast<F>(vendor_symbol(library, name));
}

}  // namespace pmg::gpu::detail

/// The name a vendor header's macro gives a function (cublasCreate is cublasCreate_v2), as text.
#define PMG_VENDOR_NAME(fn) PMG_VENDOR_TEXT(fn)
/// `x` as text, after expansion by PMG_VENDOR_NAME.
#define PMG_VENDOR_TEXT(x) #x
/// The vendor function `fn` of library `lib` (cublas or cusparse), resolved once per call site.
#define PMG_VENDOR(lib, fn)                                                                           \
  ([]() {                                                                                             \
    static const auto f = ::pmg::gpu::detail::vendor_function<decltype(&fn)>(                        \
        ::pmg::gpu::detail::lib##_library(), PMG_VENDOR_NAME(fn));                                   \
    return f;                                                                                         \
  }())
