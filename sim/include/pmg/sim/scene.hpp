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

/// A simulation scene as read and checked from JSON (see the file comment); the defaults are the
/// built-in scene. Units are SI (m, s, kg, N, Pa).
struct Scene {
  /// Where the scene came from, for reports: the file path, or the scene's name with the path.
  std::string source = "built-in default scene";
  // geometry
  std::string mesh_file;                  ///< empty: the box bar
  std::array<int, 3> box{8, 2, 2};       ///< boxes of 24 tets along x y z
  /// Side lengths of the box bar along x y z (ignored with a mesh file).
  std::array<double, 3> size{4.0, 1.0, 1.0};
  int refine = 0;                         ///< uniform refinements of the mesh (8x elements each)
  /// mesh.allow: ["tangled", "cracked"] accepts a mesh file check_mesh() would refuse (the
  /// orientation is always fixed when a file is read).
  fem::MeshCheckOptions mesh_checks;
  /// Polynomial degree of the finest level, 1 to 3 (the hierarchy holds degrees 1 to this).
  int degree = 3;
  /// "displacement" (the default) or "mixed": the displacement-pressure elements of
  /// pmg/fem/mixed.hpp (outside_mixed_scope() says what they take; solver mixed-gmres unless the
  /// scene names mumps). A scene's "auto" is made concrete when it is read: mixed from ν >=
  /// kMixedFromPoisson where the scene is in the mixed scope, displacement otherwise.
  std::string formulation = "displacement";
  /// How "auto" was made concrete, in words (empty when the scene named its formulation).
  std::string formulation_choice;
  // material
  /// Corotational material (material.model "corotational"); false: linear.
  bool corotational = true;
  /// \var poisson
  /// Poisson's ratio, in (-1, 0.5); up to 0.5 with the mixed formulation.

  /// Young's modulus E in Pa (> 0).
  double young = 5e6, poisson = 0.3, density = 1000.0;  ///< mass density in kg/m³ (>= 0)
  /// Optional stiff (or soft) inclusion: elements whose centroid lies in [min, max] get this E.
  bool inclusion = false;
  /// Lower corner of the inclusion's box (below inclusion_max in every coordinate).
  fem::Vec3 inclusion_min = fem::Vec3::Zero(), inclusion_max = fem::Vec3::Zero();  ///< upper corner
  /// Young's modulus of the inclusion's elements in Pa (> 0 when `inclusion`).
  double inclusion_young = 0.0;
  // constraints: the vertices within `clamp_fraction` of the minimum of `clamp_axis` (none: -1)
  /// Axis whose minimum is clamped: 0, 1, 2 for x, y, z; -1: nothing clamped.
  int clamp_axis = 0;
  /// Clamped slab as a fraction of the extent along clamp_axis, in [0, 1); 0 clamps the vertices
  /// at the minimum only.
  double clamp_fraction = 0.0;
  /// A boundary face held in some components, at zero: a roller or sliding support, or a symmetry
  /// plane (which holds its normal component). The vertices at the minimum or maximum of `axis`
  /// (within 1e-9 of the extent), on every level (fem::ElasticityModel::constrain_components).
  struct Support {
    int axis = 0;         ///< 0, 1, 2 for x, y, z
    bool at_max = false;  ///< the face at the maximum of axis (else the minimum)
    int components = 0;   ///< bits 1, 2, 4 for x, y, z held (1 to 7)
  };
  /// Scene keys "supports" ([{"axis", "at": "min"|"max", "components": "xyz" subset}]) and
  /// "symmetry" ([{"axis", "at"}]: components = the axis). They add to the clamp (a static scene
  /// still needs one), run on one process (petsc-mgpcg refuses them) and do not combine with an
  /// initial state that prescribes displacements (compressed, twisted, spinning).
  std::vector<Support> supports;
  // loads (constant in time)
  /// Gravitational acceleration in m/s² (zero: no gravity load).
  fem::Vec3 gravity = fem::Vec3::Zero();
  fem::Vec3 end_force = fem::Vec3::Zero();  ///< total force on the far face (max of the clamp axis)
  // initial state
  std::string initial = "rest";  ///< rest, deflected, compressed, twisted, spinning
  fem::Vec3 initial_force{0.0, 0.0, -4000.0};  ///< deflected: static shape under this end force
  double strain = 0.2;                         ///< compressed: shortening along the clamp axis
  double twist_degrees = 90.0;                 ///< twisted: rotation of the far end
  fem::Vec3 omega{0.0, 0.0, 2.0};              ///< spinning: angular velocity [rad/s]
  // time
  /// Time stepping; false for a static scene (time "static").
  bool dynamic = true;
  /// Time step in seconds (see check_time()).
  double dt = 0.01, duration = 2.0;  ///< simulated time in seconds (see check_time())
  /// The most time steps a scene may ask for.
  static constexpr double kMaxSteps = 1e7;
  /// Empty if dt and duration are usable (finite, > 0, between one and kMaxSteps steps), else why
  /// not. read_scene checks it; so must anything that overrides dt or duration.
  std::string check_time() const;
  /// Rayleigh damping C = α M + β K: α in 1/s (>= 0; fem::SimulationParams).
  double rayleigh_alpha = 0.0, rayleigh_beta = 0.0;  ///< β in s (>= 0)
  // solver: the solver factory's options (pmg/sparse/factory.hpp), checked when it is built
  /// The step solver's options for the solver factory, with the defaults of set_solver_defaults().
  Config solver = default_solver();
  /// A solver Config holding only the defaults of set_solver_defaults() for a dynamic or static
  /// scene.
  static Config default_solver(bool dynamic = true, bool mixed = false);
  /// Where the scene sets none: dynamic, method pmg, tol 1e-3, max_iterations 1000; static, method
  /// cholmod (an iterative method: tol 1e-10, max_iterations 10000).
  /// A mixed scene's method is mixed-gmres (tol 1e-5 per step, 1e-10 static) unless it names one.
  static void set_solver_defaults(Config& c, bool dynamic = true, bool mixed = false);
  // output
  std::string output;  ///< directory; empty: nothing written
  /// A .vtu frame every this many steps, and after the last step (0: no frames).
  int frame_every = 10;
  bool energy = true;                 ///< record energies each step
  std::optional<fem::Vec3> probe;     ///< rest point whose displacement is recorded
};

/// The box bar of the seed's solver tables, the system of `pmg compare` and `pmg coarse` without a
/// mesh: 5 x 1 x 1 boxes of 24 tetrahedra over 1 x 0.2 x 0.2 m, fem::Material's defaults
/// (E = 500 kPa, ν = 0.3, ρ = 1000 kg/m³), clamped at x = 0, 10 N downwards spread over the far
/// face, static. (Scene{} is the built-in simulation scene, the larger 4 m cantilever.)
Scene table_bar();

/// The Poisson's ratio from which "formulation": "auto" takes the mixed elements. Measured
/// (docs/robustness.md, "Choosing"): below it the displacement-only elements are within 1.7x of the
/// mixed displacement error and faster; at ν = 0.49 their quadratic displacement error is 2.5x and
/// their pressure error 3.5x the mixed ones.
inline constexpr double kMixedFromPoisson = 0.49;
/// Why the scene is outside what the mixed formulation takes (a phrase for a message), or nullptr:
/// degree 2 or 3, ν in (0, 1/2], no inclusion, no stiffness damping.
const char* outside_mixed_scope(const Scene& s);

/// Reads and checks a scene; `path` names the file in every message.
Scene read_scene(const std::string& path);
/// The same from JSON text; `path` names it in messages, and a relative mesh.file is taken
/// relative to its folder.
Scene parse_scene(const std::string& text, const std::string& path);
/// The scene as JSON (what --print-scene shows; read_scene accepts it back).
std::string scene_to_json(const Scene& s);

}  // namespace pmg::sim
