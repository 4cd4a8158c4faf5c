// Internal to pmg::fem: the element kernels of the matrix-free elasticity operator, defined in
// matrix_free_kernels.cpp for degrees 1-3 (and float or double for the batched product).
#pragma once

#include "pmg/fem/element_kernel.hpp"
#include "pmg/fem/matrix_free.hpp"

namespace pmg::fem::detail {

/// Element data, 16 doubles: g_k = R ∇λ_k (row-major 4x3), then 6V p² s λ_e, 6V p² s μ_e, 6V ρ m
/// (pmg/fem/element_kernel.hpp).
constexpr int kData = kElementData;
/// Elements per batch of the batched product (one per SIMD lane; the last batch padded).
constexpr int kBatch = 16;

/// Where datum k of the element at batch position pos sits in the batch layout (kData x kBatch
/// per batch, datum-major).
inline size_t batch_datum(long pos, int k) {
  return (static_cast<size_t>(pos / kBatch) * kData + static_cast<size_t>(k)) * kBatch + static_cast<size_t>(pos % kBatch);
}

/// r = (m M_e + s K_R,e) u for one element with data d; u[a][i]: component i of node a.
template <int P>
void element_product(const double* d, const double (&u)[ElementKernelTables<P>::N][3],
                     double (&r)[ElementKernelTables<P>::N][3]);

/// out += sign · (element products of x) over elements [begin, end), one element at a time (N node
/// indices per element; a free index < 0 is a fixed node: read as 0, not written). The data are in
/// the batch layout (batch_datum()), element e at position pos[e] (pos nullptr: at e).
template <int P>
void apply_elements(const index_t* free, const double* batch_data, const index_t* pos, long begin, long end,
                    const double* xp, double* out, double sign);

/// The nodes of a thread's batches that other threads' batches hold as well: in the batch index
/// array, an index <= -2 stands for slot s = -2 - index, gathered from x at free index nodes[s] and
/// scattered into out[3s, 3s + 3) (the thread's own buffer, added to the result after the threads).
template <class T>
struct SharedSlots {
  const index_t* nodes = nullptr;
  T* out = nullptr;
};

/// The same over batches [begin, end) of kBatch elements (node indices node-major, data
/// datum-major per batch), with kernel k (not automatic); mass: add the mass term. Index -1: a
/// fixed node or a padding lane; <= -2: a shared slot.
template <int P, class T>
void apply_element_batches(MatrixFreeKernel k, const index_t* free, const T* data, long begin, long end, const T* xp,
                           T* out, SharedSlots<T> shared, T sign, bool mass);

/// The elastic state of batches [begin, end) (ElasticityOperator::element_force): force −= K_R,e y_e
/// and the return value ½ Σ_e y_eᵀ K_R,e y_e, y_a = (X_a + u_a) − R_e X_a. `nodes` holds every
/// element node's index (X and u have 3 entries per node; padding lanes -1); an index <= -2 is
/// shared slot s = -2 - index: node shared.nodes[s], written into shared.out[3s, 3s + 3).
/// `elements`: each lane's element (-1: padding); R: 9 entries per element (column-major;
/// nullptr: R = I). The batch data's Lamé factors are scaled by inv_weight (the stiffness alone).
/// Kernel k as apply_element_batches (not reference).
template <int P>
double force_element_batches(MatrixFreeKernel k, const index_t* nodes, const index_t* elements, const double* data,
                             double inv_weight, const double* X, const double* u, const double* R, long begin,
                             long end, double* force, SharedSlots<double> shared);

/// The kernel `automatic` stands for on this CPU (any other is returned as it is).
MatrixFreeKernel resolve_kernel(MatrixFreeKernel k);

}  // namespace pmg::fem::detail
