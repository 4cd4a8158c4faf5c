// pmg/fem/hierarchy.hpp — the degree hierarchy of p-multigrid on one mesh: models of degree
// p, p-1, ..., 1 with the same material and Dirichlet set, their matrices (re-discretised with the
// same rotations: the "geometric" coarse operators), and the transfers between them over the free
// nodes. It is a mg::LevelProvider: pmg::multigrid builds its cycles from it (through the solver
// factory, pmg/sparse/factory.hpp) exactly as from a user's own levels.
//
// Prolongation by degree elevation (exact: the BB spaces are nested):
//   b^p_α = Σ_{k: α_k>0} (α_k/p) b^{p-1}_{α-e_k}
// The seed's interpolating restriction (an option to compare with R = Pᵀ): cubic→quadratic copies
// the vertex coefficients and sets the edge coefficient to (-b_30 + 3 b_21 + 3 b_12 - b_03)/4 (the
// quadratic interpolating the cubic at the edge midpoint); quadratic→linear drops the edge nodes.
#pragma once

#include "pmg/fem/elasticity.hpp"
#include "pmg/fem/matrix_free.hpp"
#include "pmg/sparse/level_provider.hpp"
#include "pmg/sparse/solver.hpp"

#include <functional>
#include <memory>
#include <vector>

namespace pmg::fem {

class BoundSystem;
class CoarseMeshLevels;

/// Scalar prolongation (fine free nodes x coarse free nodes) from degree p-1 to degree p.
Csr degree_elevation(const BBSpace& fine, const std::vector<index_t>& fine_free,
                     const BBSpace& coarse, const std::vector<index_t>& coarse_free);
/// The seed's interpolating restriction (coarse free nodes x fine free nodes).
Csr interpolating_restriction(const BBSpace& fine, const std::vector<index_t>& fine_free,
                              const BBSpace& coarse, const std::vector<index_t>& coarse_free);

/// The p-multigrid levels of an FEM discretisation: one ElasticityModel per degree 1..p on the same
/// mesh and clamp, their matrices, mass matrices, matrix-free operators and the degree-elevation
/// prolongations between them. Holds references to the mesh, which must outlive it.
class DegreeHierarchy final : public mg::LevelProvider {
 public:
  /// Levels l = 0..degree-1 hold degree l+1; `fixed` selects the clamped mesh vertices by rest
  /// position, and every level fixes the BB nodes whose support has only clamped vertices
  /// (ElasticityModel::fix_vertices): all nodes of a clamped face, on every level alike.
  /// `components` (empty: none) holds single components on every level: one mask per vertex,
  /// bit c (1, 2, 4) for component c (ElasticityModel::constrain_components: symmetry planes,
  /// rollers); the cycles keep those components out of their transfers (constrained_dofs()).
  DegreeHierarchy(const TetMesh& mesh, int degree, const Material& material,
                  const std::function<bool(const Vec3&)>& fixed, std::vector<char> components = {});
  /// The same with the clamped vertices given as one flag per mesh vertex (1: clamped), as
  /// clamped_vertices() returns them: a rank's share of a mesh keeps its owner's clamp.
  DegreeHierarchy(const TetMesh& mesh, int degree, const Material& material, std::vector<char> clamped,
                  std::vector<char> components = {});
  /// Neither copied nor moved: its coarse-mesh levels and bound solvers refer to it by address.
  DegreeHierarchy(const DegreeHierarchy&) = delete;
  DegreeHierarchy& operator=(const DegreeHierarchy&) = delete;

  int num_levels() const override { return static_cast<int>(models_.size()); }
  std::string level_name(int level) const override { return "degree " + std::to_string(level + 1); }
  /// This hierarchy: a mesh that methods across ranks partition (LevelProvider).
  const DegreeHierarchy* partitionable_hierarchy() const override { return this; }
  /// The model of a level (degree level + 1); level is not range-checked.
  const ElasticityModel& model(int level) const { return *models_[level]; }
  /// The model of the finest level (the highest degree).
  const ElasticityModel& finest() const { return *models_.back(); }
  /// One flag per mesh vertex: 1 where `fixed` selected it.
  const std::vector<char>& clamped_vertices() const { return clamped_; }
  /// The component masks given at construction (one per vertex; empty: none).
  const std::vector<char>& component_masks() const { return components_; }
  /// The components a level holds on their own (per free dof; nullptr: none).
  const std::vector<char>* constrained_dofs(int level) const override {
    const std::vector<char>& c = model(level).constrained_free_dofs();
    return c.empty() ? nullptr : &c;
  }
  /// Per-element Young's modulus factors on every level (ElasticityModel::set_stiffness_scale).
  void set_stiffness_scale(const std::vector<double>& scale) {
    for (auto& m : models_) m->set_stiffness_scale(scale);
  }
  /// Consistent mass matrix of a level over its free nodes (assembled on first use, then kept).
  const Bcsr& mass(int level);
  /// A level's matrix (allocated on first use, zero until assembled: a level used only through
  /// its matrix-free operator never holds one).
  Bcsr& matrix(int level) { return matrix_storage(level); }
  const Bcsr& matrix(int level) const override { return matrix_storage(level); }
  /// Prolongation from level-1 to level (1 <= level < num_levels(); else InputError).
  const Csr& prolongation(int level) const override;
  Csr interpolating_restriction(int level) const override;

  /// The matrix-free operator (ElasticityOperator) of a level of degree >= 2; nullptr for the
  /// linear level, whose matrix a cycle factorises. Built on first use, then kept current: every
  /// assemble_level() and update_matrix_free() of the level gives it the same rotations and
  /// weights as the level's matrix.
  const LinearOperator* matrix_free_operator(int level) const override;
  /// True: every level of degree >= 2 has (or builds on first use) its ElasticityOperator.
  bool offers_matrix_free() const override { return num_levels() >= 2; }
  /// The rest positions of the level's free nodes.
  std::vector<double> node_coordinates(int level) const override {
    const Vector free = model(level).free_positions();
    return std::vector<double>(free.data(), free.data() + free.size());
  }
  /// The open vertex stars of a level of degree >= 2 over its free nodes (LevelProvider::
  /// vertex_patches), built on first use; nullptr for the linear level. A star with no free node
  /// (a clamped vertex whose elements are all clamped around it) is left out. Not thread-safe on a
  /// level's first call (a solver's construction makes it, before any solve).
  const std::vector<std::vector<index_t>>* vertex_patches(int level) const override;
  /// λ/μ of the material (the same on every level and element: a stiffness scale changes E only).
  double lame_ratio() const override { return finest().material().lambda() / finest().material().mu(); }
  /// The same operator as the concrete type, built on first use with the level's last rotations and
  /// weights; throws InputError for level 0 or a level out of range.
  const ElasticityOperator& matrix_free(int level) const;
  /// A level's matrix-free operator brought to rotations R (nullptr: none) and the weights
  /// mass_weight M + stiffness_weight K_R, its matrix left as it is: a matrix-free level's whole
  /// per-step work.
  void update_matrix_free(int level, const Rotations* R, double mass_weight = 0.0,
                          double stiffness_weight = 1.0);

  /// The uniform refinements that made the mesh (refine_uniform's record, coarsest first): the
  /// linear spaces of the coarser meshes become levels under this hierarchy's linear level
  /// (levels_below(), CoarseMeshLevels). Call before a solver is built on the hierarchy. Throws
  /// InputError when the record does not end at this hierarchy's mesh; an empty record removes them.
  void set_refinements(const std::vector<Refinement>& refinements);
  /// The linear levels of the coarser meshes with this hierarchy's linear level on top, or nullptr
  /// without set_refinements(). They refer to this hierarchy, which must outlive them.
  std::shared_ptr<const LevelProvider> levels_below() const override;

  /// This hierarchy bound to a solver (BoundSystem, pmg/fem/bound_system.hpp): the one seam through
  /// which every FEM caller prepares the levels the solver reads and sets it up or updates it.
  /// Both must outlive the binding.
  BoundSystem bind(Solver& solver);
  /// The rotations a level was last brought to (assemble_level(), update_matrix_free()), or
  /// nullptr for none (R = I). Every level is given the same rotations.
  const Rotations* last_rotations(int level) const { return state_.at(level).rotated ? &rotations_ : nullptr; }
  /// The weights (mass, stiffness) of a level's last assembly or update: (0, 1) until one.
  std::pair<double, double> last_weights(int level) const {
    return {state_.at(level).mass_weight, state_.at(level).stiffness_weight};
  }

  /// Assembles every level with rotations R (nullptr: linear elasticity), the same R on every
  /// level, and on the finest level also the right-hand side correction (see
  /// ElasticityModel::assemble) when rhs != nullptr. Patterns are kept; only values change.
  /// The level matrices are  mass_weight M + stiffness_weight K  (implicit Euler: M + Δt² K); the
  /// rhs correction is scaled by stiffness_weight. Mass matrices are assembled once, on first use.
  void assemble(const Rotations* R, Vector* rhs = nullptr, double mass_weight = 0.0,
                double stiffness_weight = 1.0);
  /// The same for one level.
  void assemble_level(int level, const Rotations* R, Vector* rhs = nullptr,
                      double mass_weight = 0.0, double stiffness_weight = 1.0);
  /// Level l's matrix  mass_weight M + stiffness_weight K_R  and, from the same pass over the
  /// elements (ElasticityModel::evaluate), the elastic force (full vector) and energy of the
  /// displacement u; either may be nullptr.
  void assemble_level(int level, const Rotations* R, double mass_weight, double stiffness_weight,
                      const Vector& u, Vector* force, double* energy);

 private:
  std::vector<std::unique_ptr<ElasticityModel>> models_;
  void assemble_level(int level, ElasticityModel::ElementPass pass, double mass_weight,
                      double stiffness_weight);

  mutable std::vector<Bcsr> matrices_;  ///< empty until first used
  Bcsr& matrix_storage(int level) const;
  std::vector<Bcsr> masses_;  ///< per level, assembled on first use
  std::vector<Csr> prolongations_;
  std::vector<char> clamped_;
  std::vector<char> components_;
  /// Rotations and weights of each level's last assembly or update, for operators built later.
  struct LevelState {
    bool rotated = false;
    double mass_weight = 0.0, stiffness_weight = 1.0;
  };
  std::vector<LevelState> state_;
  Rotations rotations_;  ///< the last rotations given (the same on every level)
  mutable std::vector<std::unique_ptr<ElasticityOperator>> operators_;
  mutable std::vector<std::vector<std::vector<index_t>>> patches_;  ///< per level, built on first use
  void record(int level, const Rotations* R, double mass_weight, double stiffness_weight);
  std::shared_ptr<const CoarseMeshLevels> below_;  ///< set_refinements(); nullptr: none
};

/// The linear levels of the meshes a uniformly refined mesh was made from (DegreeHierarchy::
/// levels_below): the top level is the hierarchy's linear level itself (its matrix, unknowns and
/// held components); level l < top is the linear space of the mesh top - l refinements coarser,
/// over the vertices the mesh's clamp leaves free (a coarse mesh's vertices are the fine mesh's
/// first ones, so they keep their clamp; a component held on its own is held on the top level
/// only, and a cycle's Galerkin products hold a coarse component where no free fine component
/// reads it: the coarse spaces stay subspaces of the constrained top level's). The scalar prolongation is linear
/// interpolation: 1 at a vertex the coarse mesh has, 1/2 from each end of the edge a midpoint
/// halves; exact on nested meshes. No level below the top holds a matrix: a cycle over these
/// forms Galerkin products, which equal the re-discretised coarse operators for linear elasticity
/// with a material constant per coarse element, and stay exact for per-element rotations, stiffness
/// scales and mass weights, where a re-discretisation would not.
class CoarseMeshLevels final : public LevelProvider {
 public:
  /// Checks that the record chains to the hierarchy's mesh (InputError otherwise).
  CoarseMeshLevels(const DegreeHierarchy& hierarchy, const std::vector<Refinement>& refinements);
  int num_levels() const override { return static_cast<int>(prolongations_.size()) + 1; }
  /// The top level's: the hierarchy's linear matrix; below it a matrix without entries of the
  /// level's size (has_matrix() is false there).
  const Bcsr& matrix(int level) const override;
  bool has_matrix(int level) const override { return level == num_levels() - 1; }
  const Csr& prolongation(int level) const override { return prolongations_.at(level - 1); }
  std::vector<double> node_coordinates(int level) const override;
  const std::vector<char>* constrained_dofs(int level) const override;
  double lame_ratio() const override { return hierarchy_.lame_ratio(); }
  std::string level_name(int level) const override;

 private:
  const DegreeHierarchy& hierarchy_;
  std::vector<std::vector<index_t>> vertex_of_;  ///< per level below the top: the vertex of each node
  std::vector<Csr> prolongations_;
  std::vector<Bcsr> empty_;  ///< per level below the top: its size, no entries
};

}  // namespace pmg::fem

#include "pmg/fem/bound_system.hpp"  // DegreeHierarchy::bind's result
