// pmg/sim/setup.hpp — a scene made concrete: the mesh (a file, or the box bar of 24-tetrahedron
// boxes), the degree hierarchy with its clamped vertices and material (with an optional
// inclusion), the constant external force, the probe (located once), the initial state and the
// step solver from the solver factory. `pmg simulate` is a printer around this and run.hpp.
//
//   pmg::sim::Scene scene = pmg::sim::read_scene("scenes/twisted.json");
//   pmg::sim::SceneSetup setup = pmg::sim::set_up(scene);
//   auto [u0, v0] = pmg::sim::initial_state(scene, setup);
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/mesh.hpp"
#include "pmg/sim/scene.hpp"
#include "pmg/sparse/solver.hpp"

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace pmg::dist {
class MeshProblem;
}

namespace pmg::sim {

/// A mesh file (its reader's warnings appended to `warnings` if given), its elements and vertices
/// in fem::reorder_for_locality()'s order; or, with an empty path, the box bar of box[0] x box[1] x
/// box[2] boxes of 24 tetrahedra with the given side lengths (the generator's order is local).
fem::TetMesh load_mesh_or_box(const std::string& file, const int box[3], const double size[3],
                              std::vector<std::string>* warnings = nullptr,
                              const fem::MeshCheckOptions& mesh_checks = {});

/// A lower estimate of the peak memory of a run on `tets` tetrahedra of `degree` (measured peaks of
/// `pmg simulate` on box bars: about 4, 14 and 70 KB per tetrahedron at p = 1, 2, 3; the estimate
/// takes 2, 10 and 50 so that it never refuses a run that fits). Where the finest matrix is not
/// assembled (`finest_assembled` false: matrix-free solvers only) 1.5 and 4 KB at p = 2, 3 (measured
/// 2.0 KB on the refined cubes of 2.2M and 9.6M quadratic unknowns, 3.1 KB on an unrefined one,
/// 5.7 and 6.6 KB on cubic cubes of 1.4M unknowns). set_up() refuses a scene whose estimate exceeds
/// the machine's memory before it builds anything.
double estimated_memory_bytes(double tets, int degree, bool finest_assembled = true);

/// The point whose displacement a run records: a mesh vertex (node v = vertex v on every degree),
/// or an element and barycentric coordinates found once.
struct Probe {
  /// The probe's position in the reference configuration (mesh coordinates).
  fem::Vec3 point = fem::Vec3::Zero();
  index_t vertex = -1;   ///< >= 0: the probe is this vertex
  index_t element = -1;  ///< otherwise: this element, at `barycentric`
  /// Barycentric coordinates of `point` in `element` (unused when `vertex` >= 0).
  Eigen::Vector4d barycentric = Eigen::Vector4d::Zero();
  /// The displacement of the probe under u, a full displacement vector of m (3 per node).
  fem::Vec3 displacement(const fem::ElasticityModel& m, const Vector& u) const;
};

/// What set_up_on_ranks() built, the same on every rank.
struct RankMeshSummary {
  int ranks = 1;                ///< MPI ranks of the job
  long coarse_cells = 0;        ///< cells of the mesh rank 0 made or read (0: read in parallel)
  long cells = 0;               ///< cells of all ranks after refinement
  long unknowns = 0;            ///< finest-level unknowns of all ranks
  long clamped_vertices = 0;    ///< of all ranks
  /// Seconds of each set-up stage on rank 0, in order (pmg::dist::MeshProblem::stages()).
  std::vector<std::pair<std::string, double>> stages;
};

/// Everything set_up() builds from a scene; the hierarchy and the run refer into it, so it must
/// outlive them. On a mesh no rank holds whole (set_up_on_ranks) `mesh` and `hierarchy` are empty
/// and `on_ranks` holds the rank's share instead.
struct SceneSetup {
  std::unique_ptr<const fem::TetMesh> mesh;  ///< held by pointer: the hierarchy refers to it
  /// The degree hierarchy (degrees 1 to the scene's degree) with clamp and material.
  std::unique_ptr<fem::DegreeHierarchy> hierarchy;
  Vector f_ext;                     ///< constant external force, full vector of the finest degree
  /// \var hi
  /// Upper corner of the mesh's bounding box.

  /// Lower corner of the mesh's bounding box (the mesh as refined, at rest).
  fem::Vec3 lo, hi, centre;         ///< centre of the bounding box
  /// The point whose displacement the run records (located once, here).
  Probe probe;
  std::vector<std::string> notes;     ///< what was done once or skipped, for the report
  std::vector<std::string> warnings;  ///< the mesh reader's (e.g. unused vertices)
  /// Seconds of each stage of set_up(), in order: the mesh (generated or read), its refinement,
  /// the degree hierarchy (spaces, numbering, clamp), the checks of supports, clamp and inclusion,
  /// the loads and the probe (empty after set_up_on_ranks(): rank_mesh.stages).
  std::vector<std::pair<std::string, double>> stages;
  /// The rank's share of a scene set up across the MPI ranks (set_up_on_ranks; empty otherwise):
  /// an opaque handle for DynamicRun, which needs pmg::distributed's headers to be used directly.
  std::shared_ptr<dist::MeshProblem> on_ranks;
  /// What set_up_on_ranks() built (zero otherwise).
  RankMeshSummary rank_mesh;
  /// The model of the finest degree (the scene's degree); not on a set-up across ranks.
  const fem::ElasticityModel& finest() const { return hierarchy->finest(); }
};

/// Mesh, hierarchy, clamp (refuses a clamp that leaves a rigid motion), inclusion, loads and the
/// probe (the scene's point, or the vertex with the smallest probe_key()). InputError names the
/// scene key at fault. `finest_assembled` false: the run will not assemble the finest degree's
/// matrix (matrix-free solvers only), which the memory estimate then leaves out.
SceneSetup set_up(const Scene& s, bool finest_assembled = true);
/// Where a scene without a probe point records: the vertex with the smallest key, compared in
/// order. Clamped: (distance to the centre of the far face, then the vertex farther along the
/// clamp axis, then the smaller coordinate on the next axes); nothing clamped: (minus the
/// distance from the centre, then the smaller x, y, z). The same vertex for any order of the
/// vertices, so a mesh no rank holds whole picks the serial scene's.
std::array<double, 4> probe_key(const Scene& s, const fem::Vec3& lo, const fem::Vec3& hi, const fem::Vec3& X);

/// A scene set up across the MPI ranks of the job (MPI_COMM_WORLD) on a mesh no rank holds whole
/// (pmg/distributed/mesh_problem.hpp): a `.h5` mesh read in parallel, any other mesh or the box bar
/// made on rank 0 and distributed, refined on the ranks (mesh.refine), each rank's hierarchy,
/// clamp and loads from its own cells; the bounding box over the ranks; the probe point (the
/// scene's, or the vertex with the smallest probe_key()); supports, symmetry planes and an
/// inclusion from each rank's own vertices and cells. Collective. Throws InputError (on every
/// rank) for degree 1 and where the build has no pmg::distributed. A run of it (DynamicRun, or
/// solve_static for a static scene) solves with petsc-mgpcg, whatever method the scene names,
/// taking the scene's stopping rule.
SceneSetup set_up_on_ranks(const Scene& s);

/// Force F spread as a uniform traction over the boundary faces at the maximum of `axis` (total
/// force F). Throws InputError if there is no such face.
Vector end_force(const fem::ElasticityModel& m, int axis, double hi, double tol, const fem::Vec3& F);

/// Initial displacement and velocity (full vectors; clamped nodes at rest): rest, deflected (a
/// static solve under the scene's initial force), compressed, twisted or spinning.
/// formula_state() gives the last three.
std::pair<Vector, Vector> initial_state(const Scene& s, SceneSetup& setup);
/// The initial states given by a formula on a model whose mesh spans the box [lo, hi] (its own or,
/// on a rank of a distributed mesh, every rank's): compressed, twisted or spinning as full vectors
/// of `m`, clamped nodes at rest; zero vectors for rest and deflected (a static solve, which
/// initial_state() and a run across ranks make themselves). InputError for a state that needs a
/// clamp axis where the scene has none.
std::pair<Vector, Vector> formula_state(const Scene& s, const fem::ElasticityModel& m, const fem::Vec3& lo,
                                        const fem::Vec3& hi);

/// The step solver from the scene's solver options, through the one factory, with a rounding
/// floor for warm starts. Degree 1 has no lower degree: a multigrid method falls back to CHOLMOD
/// (with a note). `method` and `settings` receive the method and the options used.
std::unique_ptr<Solver> make_step_solver(const Scene& s, const fem::DegreeHierarchy& h,
                                         std::string& method, std::string& settings,
                                         std::vector<std::string>& notes);

}  // namespace pmg::sim
