// FEM systems for the tools: a mesh (file or the seed's box bar), a degree, a material, supports
// and a load, assembled on every level of the degree hierarchy (what PMG needs).
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/mesh.hpp"
#include "pmg/sparse/config.hpp"

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

namespace pmg::tools {

struct SceneOptions {
  std::string mesh;                 ///< .msh/.node/.ele; empty: the box bar below
  std::vector<int> box{5, 1, 1};    ///< boxes of 24 tets along x, y, z
  std::vector<double> size{1.0, 0.2, 0.2};
  int degree = 3;
  double young = 500e3, poisson = 0.3, density = 1000.0;
  std::string fix = "x";            ///< axis whose minimum face (plus fix_fraction) is clamped
  double fix_fraction = 0.0;        ///< of the extent along that axis
  std::string load = "traction";    ///< traction (10 N on the max face of `fix`'s axis, -z) | gravity
  double dt = 0.0;                  ///< > 0: implicit-Euler system M + dt² K, b = dt f
};

/// Registers the scene options on a subcommand.
void add_scene_options(CLI::App* sub, SceneOptions& o);

struct FemSystem {
  fem::TetMesh mesh;
  std::unique_ptr<fem::DegreeHierarchy> hierarchy;
  Vector b;                      ///< right-hand side over the free dofs of the finest level
  std::string description;
  double finest_assembly = 0.0;  ///< seconds to assemble the finest level
  double mass_weight = 0.0, stiffness_weight = 1.0;
  const Bcsr& matrix() const { return hierarchy->matrix(hierarchy->num_levels() - 1); }
  /// Assembles the lower levels (PMG's extra set-up work); returns the seconds it took.
  double assemble_lower_levels();
};

FemSystem build_fem_system(const SceneOptions& o);

/// When a solver configuration uses hypre (a method starting "boomeramg" anywhere in it), starts
/// MPI now — its start-up is paid once per process, not per solve — and returns the seconds it
/// took; otherwise returns a negative number and does nothing.
double start_mpi_for_hypre(const Config& config);

/// A mesh file (warnings to stderr), or with an empty path the box bar of nx x ny x nz boxes.
fem::TetMesh load_mesh_or_box(const std::string& file, const int box[3], const double size[3]);

}  // namespace pmg::tools
