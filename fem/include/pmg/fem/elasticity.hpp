// pmg/fem/elasticity.hpp — linear and corotational elasticity on degree-p BB tetrahedra.
//
// Displacements are full vectors of 3 entries per BB node (node-major). Systems are assembled over
// the free nodes only (Dirichlet nodes are eliminated): a reduced vector holds 3 entries per free
// node, in node order.
//
// Corotational (one rotation per element, from the linear part): F = Σ_i x_i ∇λ_iᵀ over the four
// vertices, x_i = X_i + u_i; F = R S with R a proper rotation (det R = +1 even for inverted
// elements). K_e^R = R K_e Rᵀ blockwise; elastic force f_e = -R K_e (Rᵀ x_e - X_e). Linear elasticity
// is R = I.
#pragma once

#include "pmg/fem/assembly.hpp"
#include "pmg/fem/element.hpp"

#include <functional>
#include <memory>

namespace pmg::fem {

/// Isotropic material. check() rejects NaN, E <= 0, ν outside (-1, 0.5), density < 0.
struct Material {
  double young = 500e3;   ///< Pa
  double poisson = 0.3;   ///< -
  double density = 1e3;   ///< kg/m³
  /// Throws InputError naming the first value out of range (see the struct comment).
  void check() const;
  /// First Lamé parameter λ = E ν / ((1 + ν)(1 - 2ν)), Pa.
  double lambda() const { return young * poisson / ((1 + poisson) * (1 - 2 * poisson)); }
  /// Shear modulus (second Lamé parameter) μ = E / (2 (1 + ν)), Pa.
  double mu() const { return young / (2 * (1 + poisson)); }
};

/// Proper rotation of the polar decomposition F = R S (SVD-based; for det F < 0 the axis of the
/// smallest singular value is flipped so that det R = +1).
Mat3 polar_rotation(const Mat3& F);

/// Dimension of the affine hull of the clamped vertices: -1 (none), 0 (one point), 1 (a line),
/// 2 or 3. Clamping removes every rigid motion only when it is at least 2.
int clamped_dimension(const TetMesh& mesh, const std::vector<char>& clamped);

/// One rotation per element (corotational elasticity), in element order.
using Rotations = std::vector<Mat3>;

/// Linear or corotational elasticity on the degree-p BB space of a tetrahedral mesh: Dirichlet
/// nodes, assembly, forces, energies, loads and point evaluation (see the file comment). Holds a
/// reference to the mesh, which must outlive it.
class ElasticityModel {
 public:
  /// Checks material and element geometry (MeshError names a degenerate or inverted element).
  ElasticityModel(const TetMesh& mesh, int degree, const Material& material);
  /// The same on the rest geometry of another model of this mesh (shared_geometry()), which is
  /// not computed again: the degrees of a hierarchy keep one copy. Throws InputError when its
  /// size is not the mesh's number of elements.
  ElasticityModel(const TetMesh& mesh, int degree, const Material& material,
                  std::shared_ptr<const std::vector<ElementGeometry>> geometry);

  /// The BB space (nodes, positions, element-to-node map).
  const BBSpace& space() const { return space_; }
  /// The (homogeneous) material; see stiffness_scale() for per-element Young's moduli.
  const Material& material() const { return material_; }
  /// Number of BB nodes, fixed ones included.
  index_t num_nodes() const { return space_.num_nodes(); }
  /// Entries of a full vector: 3 per node.
  index_t num_dofs() const { return 3 * space_.num_nodes(); }

  // ---- Dirichlet conditions (set before the first assembly) -------------------------------------
  /// Fixes every node whose rest position satisfies the predicate (all BB nodes of a face lying in
  /// a plane, say: that fixes the face exactly).
  void fix_where(const std::function<bool(const Vec3&)>& predicate);
  /// Fixes the given nodes. Throws InputError for a node that does not exist, and Error (as every
  /// fix_* call) after the first assembly.
  void fix_nodes(const std::vector<index_t>& nodes);
  /// Fixes every node whose support sub-simplex (the vertex, edge, face or tet it belongs to) has
  /// only clamped vertices: the same clamped set on every degree, so the fixed spaces are nested
  /// and prolongation maps free coarse nodes to free fine nodes. `clamped` has one entry per vertex.
  void fix_vertices(const std::vector<char>& clamped);
  /// Holds single components at zero (symmetry planes, rollers, sliding supports): one mask per
  /// vertex, bit c (1, 2, 4 for x, y, z) set where component c is held. A node gets bit c when
  /// every vertex of its support sub-simplex has it (as fix_vertices: on a plane through a mesh
  /// face, every node of the face); a node that gets all three bits is fixed. The other nodes
  /// with bits stay free with those components as identity rows — 1 on the diagonal, the rest of
  /// the row and column zero — in every matrix (assemble, assemble_mass, evaluate) and in the
  /// matrix-free operator, and zero in every reduced vector (the rhs of assemble and evaluate,
  /// restrict_to_free), so that solves keep them at zero. Call before the first assembly, after or
  /// before the fix_* calls. Throws InputError for a wrong number of masks or a mask above 7.
  void constrain_components(const std::vector<char>& masks);
  /// Per free dof (3 per free node, assembler() order): 1 for a component held by
  /// constrain_components(); empty when none is.
  const std::vector<char>& constrained_free_dofs() const;
  /// Identity rows and zero columns of the constrained components in a matrix of assembler()'s
  /// pattern (nothing to do without constraints; InputError for another number of block rows).
  void constrain(Bcsr& A) const;
  /// Zero at the constrained components of a reduced vector (InputError for another size).
  void constrain(Vector& reduced) const;
  /// Number of fixed nodes (a count over all nodes).
  index_t num_fixed() const;
  /// Whether the node is fixed; node must lie in [0, num_nodes()) (unchecked).
  bool is_fixed(index_t node) const { return fixed_[node] != 0; }
  /// Pattern, slot map and element traversal on threads for the current fixed set (built on first use, then kept).
  const BlockAssembler& assembler() const;
  /// Entries of a reduced (free) vector: 3 per free node. Builds the assembler on first use.
  index_t num_free_dofs() const { return 3 * assembler().num_free(); }
  /// The free nodes' entries of a full vector (which must have num_dofs() entries), in node order.
  Vector restrict_to_free(const Vector& full) const;
  /// Rest positions of the free nodes, x, y, z interleaved like a free vector: the rigid-body modes
  /// of algebraic solvers (BB coefficients reproduce linear fields, so these span them exactly).
  Vector free_positions() const;
  /// Full vector from free values and the prescribed values of the fixed nodes (from `prescribed`).
  Vector expand(const Vector& free, const Vector& prescribed) const;

  // ---- rotations, matrices, forces --------------------------------------------------------------
  /// One rotation per element for the full displacement u: the polar rotation of the deformation
  /// gradient of the element's linear part (its four vertices; see the file comment).
  Rotations rotations(const Vector& u) const;

  /// What one pass over the elements computes (every output optional). Each element's rotated
  /// stiffness K_R,e = R K_e Rᵀ is built once (twice for the elements on the border
  /// between two threads' ranges) — as the stiffness of the element whose gradients
  /// ∇λ_k are rotated to R ∇λ_k, so it costs no more than K_e — and gives the matrix, the force
  /// f_e = -K_R,e (x_e - R X_e) and the energy ½ (x_e - R X_e)ᵀ K_R,e (x_e - R X_e) of the
  /// element (x_e = X_e + u_e). On the threads by the assembler's element ranges
  /// (pmg/fem/element_ranges.hpp): no locks; matrix, force and right-hand side bitwise the same on
  /// any number of threads (the energy sums per-thread parts).
  struct ElementPass {
    const Vector* u = nullptr;           ///< full displacement; nullptr: the rest state (u = 0)
    const Rotations* R = nullptr;        ///< one per element; nullptr: R = I (linear elasticity)
    Bcsr* stiffness = nullptr;           ///< K_ff (assembler()'s pattern), overwritten with
                                         ///< stiffness_weight K_ff, or that added to it
    double stiffness_weight = 1.0;       ///< factor of K_ff in `stiffness` (a step's Δt β + Δt²)
    bool add_to_stiffness = false;       ///< keep the values (e.g. m M) and add to them
    Vector* force = nullptr;             ///< elastic force, full vector, overwritten
    double* energy = nullptr;            ///< elastic energy
    Vector* rhs = nullptr;               ///< free vector: += f_el|free - K_fd u_d (see assemble)
    const Vector* prescribed = nullptr;  ///< u_d for rhs (full vector; empty or nullptr: zero)
  };
  /// Runs one pass over the elements computing the outputs `pass` asks for. Throws InputError when
  /// a given output or input has the wrong size (or the matrix not assembler()'s pattern).
  void evaluate(const ElementPass& pass) const;
  /// K_ff for rotations R (nullptr: linear elasticity) into K (a matrix of assembler()'s pattern),
  /// and if rhs != nullptr: rhs -= K_fd u_d + Σ_e R K_e (Rᵀ X_e - X_e) restricted to the free nodes,
  /// with u_d the prescribed values in `prescribed` (a full vector; may be empty for zero).
  void assemble(const Rotations* R, const Vector& prescribed, Bcsr& K, Vector* rhs) const;
  /// Consistent mass M_ab = ρ ∫ B_a B_b dV · I₃ over the free nodes, into a matrix of assembler()'s
  /// pattern (rotation invariant: assembled once).
  void assemble_mass(Bcsr& M) const;
  /// BB row-sum lumped masses per node, m_a = ρ ∫ B_a dV (all positive; full, one per node).
  Vector lumped_mass() const;
  /// Elastic forces f = Σ_e -R K_e (Rᵀ x_e - X_e) (full vector).
  Vector elastic_force(const Vector& u, const Rotations* R) const;
  /// Σ_e ½ (Rᵀ x_e - X_e)ᵀ K_e (Rᵀ x_e - X_e).
  double elastic_energy(const Vector& u, const Rotations* R) const;

  // ---- loads (full vectors) ---------------------------------------------------------------------
  /// Gravity: f_a = ρ g ∫ B_a = ρ g V / C(p+3,3) per element node.
  Vector gravity(const Vec3& g) const;
  /// Point force F at x: F B_a(λ(x)) in the element containing x. Throws if x is outside the mesh.
  void add_point_force(Vector& f, const Vec3& x, const Vec3& F) const;
  /// Uniform traction t (force per area) on every boundary face whose three vertices satisfy
  /// on_face: t ∫_face B_a dA = t A / C(p+2,2) for the face's nodes. Returns the area loaded.
  double add_traction(Vector& f, const std::function<bool(const Vec3&)>& on_face, const Vec3& t) const;
  /// Body force density b(x) [N/m³] integrated by quadrature exact to the given degree.
  Vector body_force(const std::function<Vec3(const Vec3&)>& b, int quadrature_degree) const;

  // ---- evaluation -------------------------------------------------------------------------------
  /// Element containing rest point X and its barycentric coordinates; throws if outside.
  std::pair<index_t, Eigen::Vector4d> locate(const Vec3& X) const;
  /// The displacement u (full vector) at rest point X: locate() then evaluation of the BB
  /// polynomial. Throws InputError when X lies outside the mesh. Cost: a scan of every element.
  Vec3 displacement_at(const Vector& u, const Vec3& X) const;
  /// The same at a point located once (element and barycentric coordinates from locate()).
  Vec3 displacement_at(const Vector& u, index_t element, const Eigen::Vector4d& barycentric) const;
  /// BB coefficients of the interpolant of u(X) at every node's domain point (exact for
  /// polynomials of degree <= p).
  Vector interpolate(const std::function<Vec3(const Vec3&)>& u) const;

  /// Rest geometry of element e (volume, barycentric gradients); e is not range-checked.
  const ElementGeometry& geometry(index_t e) const { return (*geometry_)[e]; }
  /// Every element's rest geometry, shareable with another model of the same mesh.
  const std::shared_ptr<const std::vector<ElementGeometry>>& shared_geometry() const { return geometry_; }

  /// Heterogeneous stiffness: element e's Young's modulus is material().young * scale[e] (ν and ρ
  /// stay). One positive finite factor per element; an empty vector restores the homogeneous body.
  void set_stiffness_scale(std::vector<double> scale);
  /// The per-element factors of Young's modulus (empty: homogeneous).
  const std::vector<double>& stiffness_scale() const { return stiffness_scale_; }

 private:
  /// evaluate() of a degree-1 pass that asks for the matrix only (no right-hand side, force or
  /// energy): row by row (BlockAssembler::row_entries), without the slot map.
  void assemble_linear_by_rows(const ElementPass& pass) const;

  const TetMesh& mesh_;
  BBSpace space_;
  Material material_;
  const ElementTables& tables_;
  std::shared_ptr<const std::vector<ElementGeometry>> geometry_;  ///< per element; shared by a hierarchy's degrees
  std::vector<char> fixed_;
  std::vector<char> components_;                     ///< per node: bits of held components (empty: none)
  mutable std::vector<char> constrained_free_;       ///< per free dof, built with the assembler
  std::vector<double> stiffness_scale_;  ///< empty: homogeneous
  mutable std::unique_ptr<BlockAssembler> assembler_;
};

}  // namespace pmg::fem
