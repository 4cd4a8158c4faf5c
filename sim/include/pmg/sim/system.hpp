// pmg/sim/system.hpp — the linear system of a scene, as pmg compare and pmgkit.study solve it: the
// static stiffness system K u = f, or with a time step dt the system of one undamped
// implicit-Euler step (M + dt² K) v = dt f, over the free unknowns of the scene's finest degree,
// with the scene's degree hierarchy for multigrid methods. The one FEM-system type of the CLI and
// Python.
//
//   pmg::sim::SceneSystem sys = pmg::sim::system_of(pmg::sim::read_scene("scene.json"));
//   pmg::study::StudySystem ss;  ss.hierarchy = &sys.hierarchy();  ss.b = sys.b;  ...
#pragma once

#include "pmg/fem/bound_system.hpp"
#include "pmg/sim/setup.hpp"

#include <string>
#include <vector>

namespace pmg::sim {

/// A scene's linear system (see the file comment).
struct SceneSystem {
  SceneSetup setup;  ///< mesh, hierarchy, clamp, external force
  Vector b;          ///< right-hand side over the free dofs of the finest level
  double finest_assembly = 0.0;   ///< seconds to assemble the finest level
  bool finest_assembled = false;  ///< whether matrix() holds the finest level's entries
  double mass_weight = 0.0;       ///< the weight of the mass M in the system (dt > 0: 1)
  double stiffness_weight = 1.0;  ///< the weight of the stiffness K (dt > 0: dt²)

  /// The scene's degree hierarchy.
  fem::DegreeHierarchy& hierarchy() const { return *setup.hierarchy; }
  /// The finest level's matrix; Error when it was not assembled (assemble_finest()).
  const Bcsr& matrix() const;
  /// Assembles the finest level's matrix with the system's weights (once; timed in finest_assembly).
  void assemble_finest();
  /// The matrices of the levels below the finest with the system's weights (exports of every
  /// level; solvers prepare what they read through fem::BoundSystem).
  void assemble_lower_levels();
  /// The system's weights (mass M + stiffness K) for fem::BoundSystem.
  fem::SystemWeights weights() const { return {mass_weight, stiffness_weight}; }
  /// x, y, z of the finest level's free nodes (rest positions), interleaved like the unknowns: the
  /// rigid-body modes of AMG baselines (BoomerAMG interpolation vectors, GAMG near-null space).
  std::vector<double> free_coordinates() const;
};

/// The system of `scene`: static (dt = 0) or one undamped implicit-Euler step of size dt > 0;
/// `assemble_finest` false leaves the finest matrix to SceneSystem::assemble_finest() (a run whose
/// solvers are all matrix-free never assembles it). Throws InputError as set_up() does.
SceneSystem system_of(const Scene& scene, double dt = 0.0, bool assemble_finest = true);

}  // namespace pmg::sim
