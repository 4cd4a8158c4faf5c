// pmg/fem/bb_space.hpp — degree-p Bernstein–Bézier basis on tetrahedra (p = 1, 2, 3) and the global
// numbering of its nodes (control points).
//
// B_a(λ) = p!/(a0! a1! a2! a3!) λ0^a0 λ1^a1 λ2^a2 λ3^a3 for multi-indices |a| = p. A node lies on the
// sub-simplex of its nonzero entries and is shared by every element holding that sub-simplex; it is
// identified by its global vertex ids together with their multiplicities. Global numbering: vertex
// nodes first (node v is vertex v), then the edge and face nodes (p = 3) in the order the elements
// meet them, element by element. Counts: V (p = 1), V + E (p = 2), V + 2E + F (p = 3).
#pragma once

#include "pmg/fem/mesh.hpp"

#include <array>
#include <vector>

namespace pmg::fem {

/// A multi-index α = (α0, α1, α2, α3), |α| = p: one Bernstein–Bézier basis function of a tetrahedron.
using MultiIndex = std::array<int, 4>;

/// The multi-indices of degree p in local order: vertices (p e_i), then edge nodes (edges 01, 02,
/// 03, 12, 13, 23; along each from its first vertex to its second), then face nodes (p = 3; faces
/// 012, 013, 023, 123).
const std::vector<MultiIndex>& multi_indices(int p);
/// The multi-indices of degree p in the order: vertices 0..3, the nodes of each listed edge (from
/// its first vertex to its second), the node of each listed face (p = 3). multi_indices() and the
/// VTK writer use it with their own edge and face orders.
std::vector<MultiIndex> ordered_multi_indices(int p, const std::array<std::array<int, 2>, 6>& edges,
                                              const std::array<std::array<int, 3>, 4>& faces);
/// Number of multi-indices of degree p: (p+1)(p+2)(p+3)/6.
int num_element_nodes(int p);
/// Local position of alpha in multi_indices(|alpha|).
int local_index(const MultiIndex& alpha);

/// B^p_alpha(λ) and its gradient with respect to λ0..λ3.
double bernstein(const MultiIndex& alpha, const Eigen::Vector4d& lambda);
/// The gradient of B^p_alpha with respect to the barycentric coordinates λ0..λ3.
Eigen::Vector4d bernstein_gradient(const MultiIndex& alpha, const Eigen::Vector4d& lambda);

/// The degree-p Bernstein–Bézier space of a tetrahedral mesh: the global node numbering and the
/// nodes' rest positions (see the file comment). Holds a pointer to the mesh, which must outlive
/// it.
class BBSpace {
 public:
  /// Numbers the nodes of `mesh` for degree 1, 2 or 3 (InputError otherwise).
  BBSpace(const TetMesh& mesh, int degree);

  /// Polynomial degree p (1 to 3).
  int degree() const { return p_; }
  /// Nodes per element: (p+1)(p+2)(p+3)/6.
  int nodes_per_element() const { return n_; }
  /// Number of global nodes (see the file comment for the counts).
  index_t num_nodes() const { return static_cast<index_t>(positions_.size()); }
  /// Number of distinct mesh edges.
  index_t num_edges() const { return num_edges_; }
  /// Number of distinct mesh faces (triangles).
  index_t num_faces() const { return num_faces_; }
  /// The mesh the space was built on.
  const TetMesh& mesh() const { return *mesh_; }

  /// Global node of local node a (position in multi_indices(p)) of element e.
  index_t node(index_t e, int a) const { return element_nodes_[static_cast<size_t>(e) * n_ + a]; }
  /// The nodes_per_element() global nodes of element e, in multi_indices(p) order (e unchecked).
  const index_t* element_nodes(index_t e) const {
    return element_nodes_.data() + static_cast<size_t>(e) * n_;
  }
  /// Rest position X_alpha = sum_i (alpha_i / p) X_i of every node (the straight-sided control net).
  const std::vector<Vec3>& positions() const { return positions_; }

 private:
  const TetMesh* mesh_;
  int p_, n_;
  index_t num_edges_ = 0, num_faces_ = 0;
  std::vector<index_t> element_nodes_;
  std::vector<Vec3> positions_;
};

}  // namespace pmg::fem
