// pmg/fem/element.hpp — element matrices of degree-p BB tetrahedra by closed-form integration.
//
//   ∫_T λ^γ dV = 6V γ!/(|γ|+3)!,  so  ∫ B^p_a B^q_b dV = (p!/a!)(q!/b!) 6V (a+b)!/(p+q+3)!
//   ∇B^p_a = p Σ_k B^{p-1}_{a-e_k} ∇λ_k
//   S_ab = ∫ ∇B_a ∇B_bᵀ = 6V Gradᵀ G_ab Grad,  G_ab(k,l) = p² ∫ B^{p-1}_{a-e_k} B^{p-1}_{b-e_l} / (6V)
//   K_ab = λ S_ab + μ S_abᵀ + μ tr(S_ab) I₃
// The tables G_ab (4x4 per node pair) and the mass table depend only on p: they are built once per
// degree; per element only the gradients ∇λ_k (rows of D⁻¹) and V are needed.
#pragma once

#include "pmg/fem/bb_space.hpp"

#include <Eigen/Dense>

namespace pmg::fem {

/// The per-degree tables of the closed-form element integrals (see the file comment), shared by
/// every element of that degree.
struct ElementTables {
  /// The degree p.
  int p = 0, n = 0;  ///< nodes per element, (p+1)(p+2)(p+3)/6
  std::vector<Eigen::Matrix4d> G;  ///< n*n, G[a*n+b]
  Eigen::MatrixXd mass;            ///< ∫ B_a B_b / (6V)
  double load = 0.0;               ///< ∫ B_a / (6V) = 1 / (6 C(p+3,3)), the same for every a
};
/// The tables of degree p (1 to 3, InputError otherwise), built once for the program's lifetime.
const ElementTables& element_tables(int p);

/// ∫_T B^p_a B^q_b dV / (6V) for multi-indices of any degrees p, q >= 0 (closed form above).
double bernstein_product_integral(const MultiIndex& a, const MultiIndex& b);

/// Rest geometry of one element: gradients of the barycentric coordinates (row k = ∇λ_k) and volume.
struct ElementGeometry {
  /// Row k is ∇λ_k, the gradient of barycentric coordinate k (1/length).
  Eigen::Matrix<double, 4, 3> grad;
  /// Volume V of the element (> 0).
  double volume = 0.0;
};
/// Throws MeshError if the element is degenerate or inverted.
ElementGeometry element_geometry(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3);

/// Barycentric coordinates of point x in the element with the given geometry and first vertex X0.
Eigen::Vector4d barycentric(const ElementGeometry& g, const Vec3& X0, const Vec3& x);

/// Element stiffness (3n x 3n, node-major: rows 3a..3a+2 belong to node a).
void element_stiffness(const ElementTables& t, const ElementGeometry& g, double lambda, double mu,
                       Eigen::MatrixXd& K);

/// Block (a, b), a ≤ b, of the degree-1 element stiffness, the one element_stiffness() stores
/// there (block (b, a) is its transpose): with S = V ∇λ_a ∇λ_bᵀ, formed as V (∂_i λ_a ∂_j λ_b) so
/// that it is symmetric to the last bit when a = b, K_ab = λ S + μ Sᵀ + μ tr(S) I. Inline: an
/// assembly that needs no whole element matrix adds these straight into its slots.
inline Mat3 linear_element_block(const ElementGeometry& g, double lambda, double mu, int a, int b) {
  const double V = g.volume;
  Mat3 S;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) S(i, j) = V * (g.grad(a, i) * g.grad(b, j));
  const double t = mu * (S(0, 0) + S(1, 1) + S(2, 2));
  Mat3 K;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) K(i, j) = lambda * S(i, j) + mu * S(j, i) + (i == j ? t : 0.0);
  return K;
}

/// Quadrature on the reference tetrahedron in barycentric coordinates (Grundmann–Möller), exact for
/// polynomials of the given degree; weights sum to 1 (multiply by V).
struct QuadratureRule {
  /// Quadrature points as barycentric coordinates (λ0..λ3, summing to 1).
  std::vector<Eigen::Vector4d> points;
  /// One weight per point, summing to 1.
  std::vector<double> weights;
};
/// A rule exact for polynomials of degree exact_degree, built on first use and cached
/// (thread-safe); the reference stays valid for the program's lifetime.
const QuadratureRule& tet_quadrature(int exact_degree);

}  // namespace pmg::fem
