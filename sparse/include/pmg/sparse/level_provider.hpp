// pmg/sparse/level_provider.hpp — where a multigrid cycle gets its levels from.
//
// A LevelProvider hands out level matrices (3x3-block BCSR, coarsest first) and scalar node
// prolongations between them; MultigridCycle builds everything else (transfers, Galerkin
// products, smoothers, the lowest-level solver). fem::DegreeHierarchy (the BB degree hierarchy),
// StoredLevels (matrices a user built in their own code), UserLevels (CSR arrays as FEM codes
// hand them over, user_levels.hpp) and any class of a
// user's implement it the same way (MFEM's Multigrid::AddLevel, with ownership made explicit).
//
// Matrix-free levels: a provider may also hand out operators that apply a level's matrix without
// storing it (matrix_free_operator); a cycle asked for them (MultigridParams::matrix_free, the
// factory's operator=matrix-free) reads no matrix above the lowest level.
//
// Values change, patterns do not: after new values are written into the provider's matrices (a
// corotational time step re-assembles them), MultigridCycle::update() refreshes smoothers,
// Galerkin products and the lowest-level factorisation; nothing symbolic is redone.
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/csr.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg::fem {
class DegreeHierarchy;
}

namespace pmg {

/// Where a multigrid cycle gets its levels from (see the file comment): level matrices coarsest
/// first, scalar prolongations, and optionally matrix-free operators and node coordinates.
class LevelProvider {
 public:
  virtual ~LevelProvider() = default;
  /// Number of levels L >= 1; level 0 is the coarsest, L-1 the finest.
  virtual int num_levels() const = 0;
  /// The matrix of a level (3 unknowns per node, interleaved). It must stay at the same address
  /// while a cycle built from the provider lives. With Galerkin coarse operators only the finest
  /// one is read.
  virtual const Bcsr& matrix(int level) const = 0;
  /// Scalar prolongation from level-1 to level (nodes of level x nodes of level-1), level >= 1.
  virtual const Csr& prolongation(int level) const = 0;
  /// An explicit restriction (nodes of level-1 x nodes of level) instead of the transpose; only
  /// providers that define one (the BB hierarchy's interpolating restriction) override this.
  virtual Csr interpolating_restriction(int level) const {
    throw InputError("these multigrid levels define no interpolating restriction (level " +
                     std::to_string(level) + "); use the transposed prolongation");
  }
  /// Whether the level has a matrix of its own; false for levels meant for Galerkin products
  /// only (UserLevels given the finest matrix alone), which then hold an empty matrix of the
  /// right size and refuse coarse_operator=geometric.
  virtual bool has_matrix(int /*level*/) const { return true; }
  /// A matrix-free operator of the level (the same map as its matrix, applied without one), or
  /// nullptr when the provider has none (the default). A cycle with matrix_free set smooths and
  /// forms residuals with these on every level above the lowest, whose matrix it factorises; the
  /// provider keeps them current (fem::DegreeHierarchy: its degree >= 2 levels, updated with the
  /// rotations and weights of every assemble_level() or update_matrix_free()).
  virtual const LinearOperator* matrix_free_operator(int /*level*/) const { return nullptr; }
  /// Whether matrix_free_operator() gives an operator for every level above the lowest, answered
  /// without building them (the factory's operator=auto asks before choosing).
  virtual bool offers_matrix_free() const { return false; }
  /// x, y, z of the level's nodes, interleaved like its unknowns, where the provider knows them
  /// (empty otherwise, the default): the rigid-body modes of a BoomerAMG lowest level
  /// (`lowest_level.interp_vectors=rigid`).
  virtual std::vector<double> node_coordinates(int /*level*/) const { return {}; }
  /// Components constrained on their own (a symmetry plane, a roller: one or two of a node's three
  /// components fixed), or nullptr when the level has none (the default): one flag per unknown of
  /// the level (3 per node, interleaved), 1 where the component is constrained. Such a
  /// component's row and column in the level's matrix are zero but for a positive diagonal (an
  /// identity-like row); the cycle's transfers keep it out of every coarse correction and out of
  /// every restricted residual (MFEM's and deal.II's essential dofs per component). Whole clamped
  /// nodes are not listed: they are not unknowns of the level at all.
  virtual const std::vector<char>* constrained_dofs(int /*level*/) const { return nullptr; }
  /// The vertex patches of a level for Schwarz smoothing (mg::PatchSchwarz), or nullptr when the
  /// provider has none (the default): per patch the level's nodes (block rows) in it, ascending.
  /// fem::DegreeHierarchy gives the open star of each mesh vertex: the nodes of the elements around
  /// the vertex that lie on a sub-simplex containing it (the vertex's own node, the nodes inside
  /// its edges, faces and elements), the patches of Schöberl's parameter-robust multigrid for
  /// nearly incompressible elasticity and of PETSc's PCPATCH "star".
  virtual const std::vector<std::vector<index_t>>* vertex_patches(int /*level*/) const { return nullptr; }
  /// λ/μ of the levels' material where the provider knows it, 0 otherwise (the default): how
  /// nearly incompressible the problem is (λ/μ = 2ν / (1 - 2ν): 1.5 at ν = 0.3, 499 at ν = 0.499).
  /// The factory's stationary pmg smooths on vertex patches from kPatchLameRatio on.
  virtual double lame_ratio() const { return 0.0; }
  /// Levels under this provider's lowest one, where it knows nested coarser spaces there (an FEM
  /// hierarchy on a mesh made by uniform refinement: the linear spaces of the coarser meshes), or
  /// nullptr (the default). Their finest level is this provider's level 0 — the same matrix object
  /// and unknowns — and the levels below it hold no matrix of their own (Galerkin products). A
  /// cycle may then solve its lowest level by a cycle over these (the factory's coarse_meshes),
  /// which keeps them alive.
  virtual std::shared_ptr<const LevelProvider> levels_below() const { return nullptr; }
  /// For messages and timing breakdowns ("degree 3", "level 2").
  virtual std::string level_name(int level) const { return "level " + std::to_string(level); }
  /// The FEM degree hierarchy (mesh, spaces, clamp, material) behind these levels, for methods
  /// that partition the mesh across ranks (petsc-mgpcg); nullptr for levels without a mesh (user
  /// levels, stored matrices, views). The capability is asked, never cast to.
  virtual const fem::DegreeHierarchy* partitionable_hierarchy() const { return nullptr; }
};

}  // namespace pmg

namespace pmg::mg {
/// The interface's name before it moved to the core's namespace (pmgkit 0.2); kept for callers.
using pmg::LevelProvider;
}  // namespace pmg::mg
