// pmg/gpu/device.hpp — the CUDA runtime as pmgkit uses it: device discovery that never throws, a
// CudaError for every failed call, and DeviceArray<T>, the one owner of device memory.
//
// The header is plain C++ (no cuda_runtime.h): programs that use pmg::gpu build with any C++
// compiler; only the library itself is compiled by nvcc. Every call runs on the default stream,
// so a host read after a kernel sees its results (downloads synchronise).
#pragma once

#include "pmg/sparse/types.hpp"

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace pmg::gpu {

/// A CUDA runtime or library call failed (the message names the call and CUDA's error string).
class CudaError : public Error {
 public:
  using Error::Error;
};

/// Usable CUDA devices; 0 when there is none or no driver (never throws: tests use it to skip).
int device_count() noexcept;

/// Properties of a CUDA device, as device_info() reports them.
struct DeviceInfo {
  /// Device name as the driver reports it.
  std::string name;
  /// Compute capability: the major version (this line declares major and minor).
  int major = 0, minor = 0;  ///< compute capability: the minor version
  /// Number of streaming multiprocessors.
  int multiprocessors = 0;
  std::size_t global_memory = 0;  ///< total global memory, bytes
  double peak_bandwidth_gbs = 0;  ///< theoretical peak GB/s (memory clock, bus width); 0: unknown
};
/// Properties of the current device; throws CudaError when there is none.
DeviceInfo device_info();
/// Waits for every kernel launched so far; throws CudaError on a failed kernel.
void synchronize();
/// Opens cuBLAS and cuSPARSE now and resolves every function pmgkit calls in them, as the
/// baselines (CusparseBsr, CusparseCsr, LibraryPcgSolver) do on their first use; the libraries
/// are not linked, so a process that never calls them never maps them. Needs no device. Throws
/// CudaError naming the library or function that is missing.
void load_vendor_libraries();

namespace detail {
void* allocate(std::size_t bytes);
void release(void* p) noexcept;
void copy_to_device(void* dst, const void* src, std::size_t bytes);
void copy_to_host(void* dst, const void* src, std::size_t bytes);
void copy_on_device(void* dst, const void* src, std::size_t bytes);
void fill_zero(void* p, std::size_t bytes);
}  // namespace detail

/// An array in device memory, move-only, freed by its destructor. resize() keeps the allocation
/// when it is large enough, so re-uploading values of the same size never reallocates.
template <class T>
class DeviceArray {
 public:
  DeviceArray() = default;
  /// n uninitialised elements. Throws CudaError when the allocation fails.
  explicit DeviceArray(std::size_t n) { resize(n); }
  /// A device copy of `host`. Throws CudaError when allocation or copy fails.
  explicit DeviceArray(const std::vector<T>& host) { upload(host); }
  /// A device copy of the n elements at host pointer `host`. Throws CudaError on failure.
  DeviceArray(const T* host, std::size_t n) { upload(host, n); }
  ~DeviceArray() { detail::release(data_); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  /// Takes o's memory; o is left empty with no allocation.
  DeviceArray(DeviceArray&& o) noexcept
      : data_(std::exchange(o.data_, nullptr)), size_(std::exchange(o.size_, 0)),
        capacity_(std::exchange(o.capacity_, 0)) {}
  /// Frees this array's memory and takes o's; o is left empty with no allocation.
  DeviceArray& operator=(DeviceArray&& o) noexcept {
    if (this != &o) {
      detail::release(data_);
      data_ = std::exchange(o.data_, nullptr);
      size_ = std::exchange(o.size_, 0);
      capacity_ = std::exchange(o.capacity_, 0);
    }
    return *this;
  }

  /// Number of elements (not bytes).
  std::size_t size() const { return size_; }
  /// True when size() is 0.
  bool empty() const { return size_ == 0; }
  /// Device pointer to the first element (nullptr when nothing was ever allocated); not
  /// dereferenceable on the host.
  T* data() { return data_; }
  /// Device pointer to the first element (nullptr when nothing was ever allocated); not
  /// dereferenceable on the host.
  const T* data() const { return data_; }

  /// Contents are undefined after a resize that reallocates.
  void resize(std::size_t n) {
    if (n > capacity_) {
      T* p = static_cast<T*>(detail::allocate(n * sizeof(T)));
      detail::release(data_);
      data_ = p;
      capacity_ = n;
    }
    size_ = n;
  }
  /// Sets all size() elements to zero bytes (0 for arithmetic types). Throws CudaError on failure.
  void set_zero() { detail::fill_zero(data_, size_ * sizeof(T)); }
  /// Resizes to n and copies the n elements at host pointer `host` to the device (synchronous).
  /// Throws CudaError on failure.
  void upload(const T* host, std::size_t n) {
    resize(n);
    detail::copy_to_device(data_, host, n * sizeof(T));
  }
  /// Resizes to host.size() and copies `host` to the device. Throws CudaError on failure.
  void upload(const std::vector<T>& host) { upload(host.data(), host.size()); }
  /// Copies the size() elements to host memory at `host`, which must have room for them; waits
  /// for earlier kernels. Throws CudaError on failure.
  void download(T* host) const { detail::copy_to_host(host, data_, size_ * sizeof(T)); }
  /// The contents as a new host vector (see download()).
  std::vector<T> to_host() const {
    std::vector<T> h(size_);
    download(h.data());
    return h;
  }
  /// Device-to-device copy of o's contents (resized to match).
  void assign(const DeviceArray& o) {
    resize(o.size());
    detail::copy_on_device(data_, o.data_, size_ * sizeof(T));
  }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0, capacity_ = 0;
};

/// Vectors on the device: interleaved x, y, z per node, like pmg::Vector on the host.
class DeviceVector : public DeviceArray<double> {
 public:
  using DeviceArray<double>::DeviceArray;
  /// A device copy of v. Throws CudaError on failure.
  explicit DeviceVector(const Vector& v) { upload(v); }
  /// Resizes to v.size() and copies v to the device. Throws CudaError on failure.
  void upload(const Vector& v) { DeviceArray<double>::upload(v.data(), static_cast<std::size_t>(v.size())); }
  using DeviceArray<double>::upload;
  /// Resizes v to size() and copies the device contents into it (waits for earlier kernels).
  void download(Vector& v) const {
    v.resize(static_cast<Eigen::Index>(size()));
    DeviceArray<double>::download(v.data());
  }
  /// The contents as a new host Vector (see download()).
  Vector to_vector() const {
    Vector v;
    download(v);
    return v;
  }
};

}  // namespace pmg::gpu
