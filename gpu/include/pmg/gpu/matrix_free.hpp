// pmg/gpu/matrix_free.hpp — the matrix-free BB elasticity operator (pmg/fem/matrix_free.hpp) on
// the device: y = m M x + s K_R x over the free nodes, one thread per element running the lean
// element kernel of pmg/fem/element_kernel.hpp (the function the host tests check against the CPU
// operator), results added with atomics; its 3x3 diagonal blocks; and the per-step rotations
// applied on the device to the rest gradients. The atomics add in no fixed order: results vary in
// the last bits from run to run (the CPU operator's are repeatable).
//
// Status: compiled (no register spills or local memory, like every kernel of the module) and
// tested where a device is present; not yet measured on one, so neither its layout (a thread per
// element and atomics, against a warp per element with shared memory) nor its speed is settled.
#pragma once

#include "pmg/fem/matrix_free.hpp"
#include "pmg/gpu/device.hpp"

namespace pmg::gpu {

/// A copy of a fem::ElasticityOperator's element arrays on the device, with its product.
class DeviceElasticityOperator {
 public:
  /// Uploads op's element arrays (its present rotations and weights), the degree's tables and
  /// the model's rest gradients. InputError where the model holds single components (symmetry
  /// planes: not supported on the device yet).
  explicit DeviceElasticityOperator(const fem::ElasticityOperator& op);
  ~DeviceElasticityOperator();
  DeviceElasticityOperator(const DeviceElasticityOperator&) = delete;
  DeviceElasticityOperator& operator=(const DeviceElasticityOperator&) = delete;

  /// Scalar rows (3 per free node).
  index_t rows() const { return rows_; }
  /// Re-uploads op's element data (after op.update() or op.set_weights() on the host); op must be
  /// the operator this was built from or one on the same model.
  void refresh(const fem::ElasticityOperator& op);
  /// One rotation per element (R = nullptr: the identity), applied on the device to the rest
  /// gradients; the weights stay as uploaded.
  void update(const fem::Rotations* R);
  /// y = A x (y is resized).
  void multiply(const DeviceVector& x, DeviceVector& y) const;
  /// The 3x3 diagonal blocks, 9 per block row, row-major (resized).
  void diagonal_blocks(DeviceArray<double>& blocks) const;

 private:
  int degree_ = 0, nodes_ = 0;
  index_t elements_ = 0, rows_ = 0;
  DeviceArray<int> free_;
  DeviceArray<double> data_, rest_;           ///< element data; rest gradients (12 per element)
  DeviceArray<unsigned char> tables_;         ///< fem::ElementKernelTables<degree_>, as bytes
  mutable DeviceArray<double> rotations_;     ///< 9 per element, for update()
};

}  // namespace pmg::gpu
