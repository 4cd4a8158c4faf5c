#include "cuda_check.hpp"
#include "pmg/fem/element_kernel.hpp"
#include "pmg/gpu/matrix_free.hpp"

#include <vector>

#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ < 600
#error "pmg::gpu needs sm_60 or newer (atomicAdd on double)"
#endif

namespace pmg::gpu {

namespace {

using fem::ElementKernelTables;
using fem::kElementData;

/// u_e through the element's free indices (a fixed node reads 0).
struct Gather {
  const int* f;
  const double* x;
  __device__ double operator()(int a, int i) const {
    const int I = f[a];
    return I >= 0 ? x[3LL * I + i] : 0.0;
  }
};

/// r_e added into y (a fixed node's rows are not written).
struct ScatterAdd {
  const int* f;
  double* y;
  __device__ void operator()(int a, int i, double v) const {
    const int I = f[a];
    if (I >= 0) atomicAdd(y + 3LL * I + i, v);
  }
};

// y += A x, one thread per element.
template <int P>
__global__ void element_apply_kernel(int elements, const ElementKernelTables<P>* __restrict__ t,
                                     const int* __restrict__ free, const double* __restrict__ data,
                                     const double* __restrict__ x, double* __restrict__ y) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= elements) return;
  constexpr int N = ElementKernelTables<P>::N;
  const int* f = free + static_cast<long long>(e) * N;
  fem::element_apply_lean<P>(*t, data + static_cast<long long>(e) * kElementData, Gather{f, x},
                             ScatterAdd{f, y});
}

// D += diagonal blocks, one thread per (element, local node).
template <int P>
__global__ void element_diagonal_kernel(int elements, const ElementKernelTables<P>* __restrict__ t,
                                        const int* __restrict__ free, const double* __restrict__ data,
                                        double* __restrict__ D) {
  constexpr int N = ElementKernelTables<P>::N;
  const long long g = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (g >= static_cast<long long>(elements) * N) return;
  const int e = static_cast<int>(g / N), a = static_cast<int>(g % N);
  const int I = free[g];
  if (I < 0) return;
  double B[9];
  fem::element_diagonal_block<P>(*t, data + static_cast<long long>(e) * kElementData, a, B);
  for (int k = 0; k < 9; ++k) atomicAdd(D + 9LL * I + k, B[k]);
}

// d[0..11] = rest · Rᵀ per element (R = nullptr: the identity).
__global__ void element_rotate_kernel(int elements, const double* __restrict__ rest,
                                      const double* __restrict__ R, double* __restrict__ data) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= elements) return;
  fem::element_rotate(rest + 12LL * e, R ? R + 9LL * e : nullptr, data + static_cast<long long>(e) * kElementData);
}

template <int P>
const ElementKernelTables<P>* tables_of(const DeviceArray<unsigned char>& bytes) {
  return reinterpret_cast<const ElementKernelTables<P>*>(bytes.data());
}

template <int P>
void upload_tables(DeviceArray<unsigned char>& bytes) {
  const ElementKernelTables<P>& t = fem::element_kernel_tables<P>();
  bytes.upload(reinterpret_cast<const unsigned char*>(&t), sizeof(t));
}

}  // namespace

DeviceElasticityOperator::DeviceElasticityOperator(const fem::ElasticityOperator& op) {
  const fem::ElasticityModel& model = op.model();
  if (!model.constrained_free_dofs().empty())
    throw InputError("DeviceElasticityOperator: the model holds single components (symmetry planes), "
                     "which the device operator does not take yet");
  const auto arr = op.element_arrays();
  degree_ = arr.degree;
  nodes_ = arr.nodes;
  elements_ = arr.elements;
  rows_ = op.rows();
  free_.upload(arr.free, static_cast<std::size_t>(elements_) * nodes_);
  data_.upload(arr.data);
  std::vector<double> rest(12 * static_cast<std::size_t>(elements_));
  for (index_t e = 0; e < elements_; ++e) {
    const auto& g = model.geometry(e).grad;
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 3; ++j) rest[12 * static_cast<std::size_t>(e) + 3 * k + j] = g(k, j);
  }
  rest_.upload(rest);
  switch (degree_) {
    case 1: upload_tables<1>(tables_); break;
    case 2: upload_tables<2>(tables_); break;
    case 3: upload_tables<3>(tables_); break;
    default: throw InputError("DeviceElasticityOperator: degree " + std::to_string(degree_) + " (1 to 3)");
  }
}

DeviceElasticityOperator::~DeviceElasticityOperator() = default;

void DeviceElasticityOperator::refresh(const fem::ElasticityOperator& op) {
  const auto arr = op.element_arrays();
  if (arr.degree != degree_ || arr.elements != elements_ || op.rows() != rows_)
    throw InputError("DeviceElasticityOperator::refresh: the operator is not the uploaded one");
  data_.upload(arr.data);
}

void DeviceElasticityOperator::update(const fem::Rotations* R) {
  if (R && R->size() != static_cast<std::size_t>(elements_))
    throw InputError("DeviceElasticityOperator::update: one rotation per element expected");
  if (elements_ == 0) return;
  const double* Rd = nullptr;
  if (R) {
    std::vector<double> host(9 * static_cast<std::size_t>(elements_));
    for (index_t e = 0; e < elements_; ++e)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) host[9 * static_cast<std::size_t>(e) + 3 * i + j] = (*R)[e](i, j);
    rotations_.upload(host);
    Rd = rotations_.data();
  }
  element_rotate_kernel<<<detail::blocks_for(elements_), detail::kThreads>>>(elements_, rest_.data(), Rd,
                                                                              data_.data());
  PMG_LAUNCHED("element_rotate_kernel");
}

void DeviceElasticityOperator::multiply(const DeviceVector& x, DeviceVector& y) const {
  if (x.size() != static_cast<std::size_t>(rows_))
    throw InputError("DeviceElasticityOperator::multiply: x has " + std::to_string(x.size()) + " entries, the operator " +
                     std::to_string(rows_) + " rows");
  y.resize(x.size());
  y.set_zero();
  if (elements_ == 0) return;
  const unsigned g = detail::blocks_for(elements_);
  switch (degree_) {
    case 1: element_apply_kernel<1><<<g, detail::kThreads>>>(elements_, tables_of<1>(tables_), free_.data(), data_.data(), x.data(), y.data()); break;
    case 2: element_apply_kernel<2><<<g, detail::kThreads>>>(elements_, tables_of<2>(tables_), free_.data(), data_.data(), x.data(), y.data()); break;
    default: element_apply_kernel<3><<<g, detail::kThreads>>>(elements_, tables_of<3>(tables_), free_.data(), data_.data(), x.data(), y.data()); break;
  }
  PMG_LAUNCHED("element_apply_kernel");
}

void DeviceElasticityOperator::diagonal_blocks(DeviceArray<double>& blocks) const {
  blocks.resize(3 * static_cast<std::size_t>(rows_));
  blocks.set_zero();
  if (elements_ == 0) return;
  const unsigned g = detail::blocks_for(static_cast<long long>(elements_) * nodes_);
  switch (degree_) {
    case 1: element_diagonal_kernel<1><<<g, detail::kThreads>>>(elements_, tables_of<1>(tables_), free_.data(), data_.data(), blocks.data()); break;
    case 2: element_diagonal_kernel<2><<<g, detail::kThreads>>>(elements_, tables_of<2>(tables_), free_.data(), data_.data(), blocks.data()); break;
    default: element_diagonal_kernel<3><<<g, detail::kThreads>>>(elements_, tables_of<3>(tables_), free_.data(), data_.data(), blocks.data()); break;
  }
  PMG_LAUNCHED("element_diagonal_kernel");
}

}  // namespace pmg::gpu
