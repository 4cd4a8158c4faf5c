// pmg/sim/scene.hpp — a simulation scene: mesh, material, clamp, loads, initial state, time,
// solver options and outputs. Read from JSON (nlohmann::json), every key checked before any
// work starts. An unknown key, a wrong type or an impossible value is an InputError naming the key
// ("scene.json: material.poisson: must lie in (-1, 0.5), got 0.7").
#pragma once

#include "pmg/fem/mesh.hpp"
#include "pmg/sparse/config.hpp"

#include <array>
#include <optional>
#include <string>

namespace pmg::sim {

struct Scene {
  std::string source = "built-in default scene";
  // geometry
  std::string mesh_file;                  ///< empty: the box bar
  std::array<int, 3> box{8, 2, 2};       ///< boxes of 24 tets along x y z
  std::array<double, 3> size{4.0, 1.0, 1.0};
  int refine = 0;                         ///< uniform refinements of the mesh (8x elements each)
  /// mesh.allow: ["tangled", "cracked"] accepts a mesh file check_mesh() would refuse (the
  /// orientation is always fixed when a file is read).
  fem::MeshCheckOptions mesh_checks;
  int degree = 3;
  // material
  bool corotational = true;
  double young = 5e6, poisson = 0.3, density = 1000.0;
  /// Optional stiff (or soft) inclusion: elements whose centroid lies in [min, max] get this E.
  bool inclusion = false;
  fem::Vec3 inclusion_min = fem::Vec3::Zero(), inclusion_max = fem::Vec3::Zero();
  double inclusion_young = 0.0;
  // constraints: the vertices within `clamp_fraction` of the minimum of `clamp_axis` (none: -1)
  int clamp_axis = 0;
  double clamp_fraction = 0.0;
  // loads (constant in time)
  fem::Vec3 gravity = fem::Vec3::Zero();
  fem::Vec3 end_force = fem::Vec3::Zero();  ///< total force on the far face (max of the clamp axis)
  // initial state
  std::string initial = "rest";  ///< rest, deflected, compressed, twisted, spinning
  fem::Vec3 initial_force{0.0, 0.0, -4000.0};  ///< deflected: static shape under this end force
  double strain = 0.2;                         ///< compressed: shortening along the clamp axis
  double twist_degrees = 90.0;                 ///< twisted: rotation of the far end
  fem::Vec3 omega{0.0, 0.0, 2.0};              ///< spinning: angular velocity [rad/s]
  // time
  bool dynamic = true;
  double dt = 0.01, duration = 2.0;
  /// The most time steps a scene may ask for.
  static constexpr double kMaxSteps = 1e7;
  /// Empty if dt and duration are usable (finite, > 0, between one and kMaxSteps steps), else why
  /// not. read_scene checks it; so must anything that overrides dt or duration.
  std::string check_time() const;
  double rayleigh_alpha = 0.0, rayleigh_beta = 0.0;
  // solver: the solver factory's options (pmg/multigrid/factory.hpp), checked when it is built
  Config solver = default_solver();
  static Config default_solver();
  /// method pmg, tol 1e-3, max_iterations 1000 where the scene sets none.
  static void set_solver_defaults(Config& c);
  // output
  std::string output;  ///< directory; empty: nothing written
  int frame_every = 10;
  bool energy = true;                 ///< record energies each step
  std::optional<fem::Vec3> probe;     ///< rest point whose displacement is recorded
};

/// Reads and checks a scene; `path` names the file in every message.
Scene read_scene(const std::string& path);
/// The same from JSON text; `path` names it in messages, and a relative mesh.file is taken
/// relative to its folder.
Scene parse_scene(const std::string& text, const std::string& path);
/// The scene as JSON (what --print-scene shows; read_scene accepts it back).
std::string scene_to_json(const Scene& s);

}  // namespace pmg::sim
