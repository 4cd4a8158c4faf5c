// FEM systems for the tools: a mesh (file or the seed's box bar), a degree, a material, supports
// and a load, assembled on every level of the degree hierarchy (what PMG needs).
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/mesh.hpp"
#include "pmg/sim/setup.hpp"
#include "pmg/sim/system.hpp"
#include "pmg/sparse/config.hpp"

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

namespace pmg::tools {

/// The scene flags of pmg compare and pmg coarse; the defaults are sim::table_bar()'s.
struct SceneOptions {
  SceneOptions();
  std::string mesh;                 ///< .msh/.node/.ele; empty: the box bar below
  std::vector<int> box;             ///< boxes of 24 tets along x, y, z
  std::vector<double> size;         ///< side lengths [m]
  int degree = 3;
  int refine = 0;                   ///< uniform refinements of the mesh (8x elements each)
  double young, poisson, density;
  std::string fix = "x";            ///< axis whose minimum face (plus fix_fraction) is clamped
  double fix_fraction = 0.0;        ///< of the extent along that axis
  std::string load = "traction";    ///< traction (10 N on the max face of `fix`'s axis, -z) | gravity
  double dt = 0.0;                  ///< > 0: implicit-Euler system M + dt² K, b = dt f
  std::vector<std::string> allow;   ///< mesh defects accepted on purpose: tangled, cracked
  /// Symmetry planes: "y" (the minimum face of y) or "y:max", each holding its normal component.
  std::vector<std::string> symmetry;
};

/// Free components held at zero by supports and symmetry planes (constrain_components).
index_t held_components(const fem::ElasticityModel& m);

/// Registers the scene options on a subcommand.
void add_scene_options(CLI::App* sub, SceneOptions& o);

/// The FEM system of a tool: a scene's linear system (sim::SceneSystem, the type pmgkit.study
/// uses too) and its description for reports.
struct FemSystem : sim::SceneSystem {
  std::string description;
};

/// The sim::Scene these options describe (clamp, material, load); build_fem_system sets it up.
sim::Scene scene_of(const SceneOptions& o);
/// The system of these options; `assemble_finest` false leaves the finest matrix to
/// assemble_finest() (a run whose solvers are all matrix-free never assembles it).
FemSystem build_fem_system(const SceneOptions& o, bool assemble_finest = true);

}  // namespace pmg::tools
