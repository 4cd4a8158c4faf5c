// pmg/fem/matrix_free.hpp — the elasticity operator of degree-p BB tetrahedra applied without a
// matrix: y = m M x + s K_R x over the free nodes, the same map as the assembled
// ElasticityModel matrices (m: mass weight, s: stiffness weight, R: one rotation per element).
//
// Per element, through the structure of the BB stiffness instead of a stored 3n x 3n block
// (Kirby, "Fast simplicial finite element algorithms using Bernstein polynomials", 2011;
// Ainsworth, Andriamaro & Davydov, "Bernstein–Bézier finite elements of arbitrary order and optimal
// assembly procedures", 2011). With g_k = R ∇λ_k (K_R = R K Rᵀ is the stiffness of the element with
// rotated gradients) and u_α the element's coefficients (3 each):
//
//   1. gradient   H_β = Σ_k u_{β+e_k} g_kᵀ            for |β| = p-1  (∇u = p Σ_β B^{p-1}_β H_β)
//   2. moments    Ĥ_γ = Σ_β Q_γβ H_β                   Q_γβ = ∫ B^{p-1}_γ B^{p-1}_β / (6V)
//   3. stress     T_γ = 6V p² s (λ tr(Ĥ_γ) I + μ (Ĥ_γ + Ĥ_γᵀ))
//   4. transpose  r_{γ+e_k} += T_γ g_k
//   5. mass       r_α += 6V ρ m Σ_α' P_αα' u_α'         P = the degree-p mass table (m ≠ 0 only)
//
// The stress reads only tr(Ĥ) and Ĥ + Ĥᵀ, and step 2 commutes with taking the symmetric part, so
// the batched kernels form the 6 components of H_β + H_βᵀ in step 1 and run step 2 on those.
// Their flops per element (multiply and add counted separately), with n = C(p+3,3) nodes and
// q = C(p+2,3) gradient coefficients: 72q (1) + 12q² (2) + 12q (3) + 72q (4) + 6n² (5, dynamics
// only); p = 3 (n = 20, q = 10): 2.8k, +2.4k with mass. The scalar reference kernel runs step 2 on
// all 9 components (18q²). The dense element block costs 18n² = 7.2k.
// Stored per element: the rotated gradients (12 doubles), λ and μ weights and the mass weight (3),
// one pad, and the n free-node indices — 128 + 4n bytes, 208 at p = 3, about 15 bytes per unknown
// against about 1.2 KB per unknown for the cubic BCSR matrix — as the product reads them; the
// operator keeps the data once, in batches (the indices in element order and in batches), and for
// each thread count above one that has run a product (at most 4 kept) a copy of the batches'
// indices with the shared nodes marked (4n bytes each).
//
// Element batches in SIMD lanes: the product runs 16 elements at a time (consecutive in the batch
// order below), one element
// per vector lane (the element data stored structure-of-arrays per batch), gathered from x and
// scattered into y lane by lane. The kernel is compiled for the baseline x86-64, AVX2 + FMA and
// AVX-512 and chosen at run time (MatrixFreeKernel; PMG_MATRIX_FREE_KERNEL overrides); the scalar
// element-by-element kernel stays as the reference the batched ones are tested against. The same
// kernel runs in float (apply_single()).
//
// Race-free and in place: the batches follow the mesh's order (which keeps the gathers close in
// memory where nodes are numbered as the elements meet them), unless 8 contiguous ranges of it hold
// more than one free node in eight in common (a mesh generator's scattered order): then the
// model's element traversal (ElementRanges: the Morton order of the centroids), whose ranges are
// compact. apply() gives each thread a contiguous range of batches. A range writes y directly at the nodes
// only its own batches hold; the few nodes that two ranges hold are shared slots, which each range
// accumulates into a buffer of its own, added to y after the ranges (in range order, so the result
// depends on the thread count only by rounding at those nodes). The diagonal blocks run contiguous
// element ranges in mesh order (thread 0 into the result, the others into buffers over the nodes
// their range touches, added after), the element forces the assembler's traversal
// (pmg/fem/element_ranges.hpp: each node written by one thread, the same on any thread count). The
// scalar reference kernel keeps one accumulation vector per thread, summed after.

// Components the model holds on their own (ElasticityModel::constrain_components: symmetry planes)
// are identity rows and zero columns here as in the assembled matrices: x is masked before the
// element pass and y_c = x_c after it.
//
// update(R) is the only per-step work of a corotational step: it rotates the stored gradients.
// diagonal_blocks() gives the 3x3 diagonal blocks (for Jacobi and Chebyshev smoothing) from the
// same element data, element_force() the elastic force and energy of a state.
#pragma once

#include "pmg/fem/elasticity.hpp"
#include "pmg/sparse/operator.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg::fem {

/// The element kernel of the matrix-free product. `automatic` picks the widest batched kernel the
/// CPU runs (AVX-512, else AVX2 + FMA, else the baseline x86-64 one); `reference` is the scalar
/// element-by-element kernel the batched ones are tested against.
enum class MatrixFreeKernel { automatic, reference, generic, avx2, avx512 };

/// Whether this CPU (and build) runs kernel k.
bool matrix_free_kernel_available(MatrixFreeKernel k);
/// "auto", "reference", "generic", "avx2", "avx512".
std::string to_string(MatrixFreeKernel k);
/// The kernel of that name (to_string()); an unknown name is an InputError.
MatrixFreeKernel parse_matrix_free_kernel(const std::string& name);

/// The matrix-free elasticity operator y = m M x + s K_R x over a model's free nodes (see the file
/// comment).
class ElasticityOperator final : public LinearOperator, public DiagonalBlocksSource, public SinglePrecisionSource {
 public:
  /// Over the model's free nodes (its Dirichlet set must be final); R = I, m = 0, s = 1 until
  /// set. The model must outlive the operator.
  explicit ElasticityOperator(const ElasticityModel& model);
  ~ElasticityOperator() override;
  /// This operator (LinearOperator's capability query for device kernels).
  const ElasticityOperator* elasticity_operator() const override { return this; }
  const DiagonalBlocksSource* diagonal_blocks_source() const override { return this; }
  /// This operator, where it applies in float: not with components held on their own (symmetry
  /// planes), which apply_single() does not take.
  const SinglePrecisionSource* single_precision_source() const override {
    return model_->constrained_free_dofs().empty() ? this : nullptr;
  }

  index_t rows() const override { return 3 * num_free_; }
  index_t cols() const override { return rows(); }
  /// The model the operator was built on.
  const ElasticityModel& model() const { return *model_; }

  /// y = m M x + s K_R x. Weights must be finite, >= 0 and not both zero (m = 1, s = 0: the mass).
  void set_weights(double mass_weight, double stiffness_weight);
  /// The mass weight m (0 until set_weights()).
  double mass_weight() const { return mass_weight_; }
  /// The stiffness weight s (1 until set_weights()).
  double stiffness_weight() const { return stiffness_weight_; }
  /// One rotation per element (nullptr: linear elasticity, R = I).
  void update(const Rotations* R);

  /// Chooses the element kernel (default automatic); one the CPU cannot run is an InputError.
  void set_kernel(MatrixFreeKernel kernel);
  /// The kernel apply() runs (never automatic: what automatic resolved to).
  MatrixFreeKernel kernel() const;

  /// y = A x in single precision: the batched kernel on float element data (x, y, the element
  /// data and the tables rounded to float; a sum of about C(p+3,3) x 12 terms per entry, so a
  /// relative error of a few 1e-6 in ||y||). Not for models that hold single components.
  void apply_single(const Eigen::VectorXf& x, Eigen::VectorXf& y) const override;
  /// r = b - A x in single precision in the product's pass (b may be r; x distinct from r).
  void residual_single(const Eigen::VectorXf& b, const Eigen::VectorXf& x, Eigen::VectorXf& r) const override;

  void diagonal_blocks(std::vector<double>& blocks) const override;

  /// f = -Σ_e K_R,e (x_e - R X_e) (full vector, x = X + u; the stiffness alone, unweighted) and
  /// its energy ½ Σ_e (x_e - R X_e)ᵀ K_R,e (x_e - R X_e). R must be the rotations of the last
  /// update() (nullptr: R = I), which the operator's gradients carry. The batched kernels run it,
  /// force and energy the same bits on any number of threads; the reference kernel and a zero
  /// stiffness weight run the scalar element loop (the force the same bits, the energy rounded
  /// by thread count).
  void element_force(const Vector& u, const Rotations* R, Vector& force, double* energy) const;

  /// The element arrays the product runs on, in element order (see element_arrays()).
  struct ElementArrays {
    int degree = 0;                 ///< the elements' degree p
    int nodes = 0;                  ///< nodes per element, (p+1)(p+2)(p+3)/6
    index_t elements = 0;           ///< number of elements
    const index_t* free = nullptr;  ///< `nodes` free node indices per element (-1: a fixed node)
    std::vector<double> data;       ///< kElementData doubles per element (pmg/fem/element_kernel.hpp)
  };
  /// The element arrays the product runs on, in element order, for a copy on a device
  /// (pmg/fem/element_kernel.hpp). `free` points into the operator (valid until it is destroyed);
  /// `data` is a copy of the element data as of this call (the operator keeps them only in its
  /// batch layout; they change with update() and set_weights()).
  ElementArrays element_arrays() const;

  /// The cost model of one apply(): floating-point operations and the bytes it must move at least
  /// (element data once, x read once, y written and read back once).
  double flops_per_apply() const;
  /// The bytes one apply() must move at least (see flops_per_apply()).
  double bytes_per_apply() const;

 private:
  /// y = A x, or with b: y = b - A x, in float; `what` names the public call in errors.
  void apply_single_checked(const Eigen::VectorXf& x, Eigen::VectorXf& y, const Eigen::VectorXf* b,
                            const char* what) const;
  void apply_impl(const Vector& x, Vector& y) const override;
  /// r = b - A x in the same pass over the elements (r starts as b, contributions subtracted).
  void residual_impl(const Vector& b, const Vector& x, Vector& r) const override;

  struct Impl;
  const ElasticityModel* model_;
  index_t num_free_ = 0;
  double mass_weight_ = 0.0, stiffness_weight_ = 1.0;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pmg::fem
