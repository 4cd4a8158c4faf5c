// pmg/fem/mesh.hpp — a tetrahedral mesh (rest vertices + 4 vertex ids per element) and its checks.
#pragma once

#include "pmg/sparse/types.hpp"

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace pmg::fem {

/// A point or vector in space (m).
using Vec3 = Eigen::Vector3d;
/// A 3x3 matrix (rotations, gradients).
using Mat3 = Eigen::Matrix3d;
/// The four vertex ids of a tetrahedron (positively oriented after reading).
using Tet = std::array<index_t, 4>;

/// Invalid mesh or model input; the message names the element, vertex or face.
class MeshError : public InputError {
 public:
  using InputError::InputError;
};

/// A tetrahedral mesh: rest positions of the vertices and four vertex ids per element (checked by
/// check_mesh(), not on construction).
struct TetMesh {
  /// Rest positions of the vertices.
  std::vector<Vec3> vertices;
  /// Four vertex ids per element (positively oriented after check_mesh()).
  std::vector<Tet> tets;

  /// Number of vertices.
  index_t num_vertices() const { return static_cast<index_t>(vertices.size()); }
  /// Number of elements.
  index_t num_tets() const { return static_cast<index_t>(tets.size()); }
  /// Signed volume det([X1-X0, X2-X0, X3-X0]) / 6 of element e.
  double signed_volume(index_t e) const;
  /// Bounding-box diagonal (the length scale of tolerances).
  double diameter() const;
};

/// What check_mesh() accepts or repairs.
struct MeshCheckOptions {
  /// Elements with |V| below this fraction of (mean edge length)^3 / 6 count as degenerate.
  double degenerate_volume = 1e-10;
  /// Reorder the vertices of negatively oriented elements instead of rejecting them.
  bool fix_orientation = false;
  /// Accept a tangled mesh (two elements on the same side of their shared face: a vertex pushed
  /// through a face, elements overlapping) instead of rejecting it.
  bool allow_tangled = false;
  /// Accept a cracked mesh (distinct vertices at the same coordinates: an unwelded seam; boundary
  /// edges not shared by exactly two boundary faces: a non-manifold boundary).
  bool allow_cracked = false;
};

/// Sets the allow flag a defect's name selects: "tangled" or "cracked" (the names of pmg's
/// --allow option and of a scene's mesh.allow); another name is an InputError listing these.
void allow_mesh_defect(MeshCheckOptions& options, const std::string& name);
/// The names of the defects `options` allows, in that order.
std::vector<std::string> allowed_mesh_defects(const MeshCheckOptions& options);

/// Checks a mesh and throws MeshError naming the first problem: no elements, non-finite
/// coordinates, vertex ids out of range or repeated within an element, zero-volume (degenerate) or
/// inverted elements, duplicate elements, faces shared by more than two elements (non-manifold),
/// vertices used by no element; unless allowed, tangled meshes (the two elements of an interior
/// face on the same side of it, once each is positively oriented) and cracked meshes (two vertices
/// at the same coordinates, a boundary edge not shared by exactly two boundary faces).
void check_mesh(TetMesh& mesh, const MeshCheckOptions& options = {});

/// One uniform refinement's vertex parents: the refined mesh's vertices [0, coarse_vertices) are the
/// coarse mesh's, and vertex coarse_vertices + k is the midpoint of the coarse edge midpoints[k].
struct Refinement {
  index_t coarse_vertices = 0;                         ///< vertices of the coarse mesh
  std::vector<std::array<index_t, 2>> midpoints;       ///< the coarse edge of each new vertex
  /// Vertices of the refined mesh.
  index_t fine_vertices() const { return coarse_vertices + static_cast<index_t>(midpoints.size()); }
};

/// Uniform ("red") refinement, levels times: every tetrahedron is split into 8 through its edge
/// midpoints (4 corner tets and the inner octahedron cut along its shortest diagonal, which keeps
/// the shapes from degrading, Bey 1995). The geometry is unchanged (new vertices lie on the old
/// straight edges), so a sequence of refinements is a clean h-convergence study on any mesh.
/// Vertices: V + E per level; elements: 8^levels as many; every element positively oriented.
/// The coarse vertices keep their numbers, the edge midpoints follow in the order the elements
/// first meet their edges, and element e's eight children are elements 8e..8e+7. `record` (when
/// given) gets one Refinement per level, coarsest first: the nested meshes' vertex parents, from
/// which the linear levels under a refined mesh's own are made (DegreeHierarchy::set_refinements).
TetMesh refine_uniform(const TetMesh& mesh, int levels = 1, std::vector<Refinement>* record = nullptr);

/// The elements in the Z-order (Morton order) of their centroids, quantised to 21 bits per axis in
/// the mesh's bounding box: order[pos] is the element visited at position pos. Consecutive elements
/// of this order form compact pieces of the mesh.
std::vector<index_t> morton_order(const TetMesh& mesh);

/// The same mesh with its elements in morton_order() and its vertices renumbered in the order
/// those elements first meet them (element orientation and the vertex order within an element
/// kept). A mesh generator's or file's order can scatter neighbours across the arrays; in this
/// order the elements, and the BB nodes numbered from them (BBSpace), that a thread's contiguous
/// range touches lie close together in memory, and two threads' ranges share few cache lines.
/// The geometry, and so every result up to rounding, is unchanged.
TetMesh reorder_for_locality(const TetMesh& mesh);

}  // namespace pmg::fem
