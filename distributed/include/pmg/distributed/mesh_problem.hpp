// pmg/distributed/mesh_problem.hpp — a static elasticity problem whose mesh no rank holds whole:
// rank 0 makes (or reads) the coarse mesh, or every rank reads a share of a mesh file in PETSc's
// HDF5 format; DMPlex distributes it (METIS's partition made on rank 0, or PT-Scotch's), every rank
// refines its part (pmg/petsc/plex.hpp) and builds its share of the degree hierarchy
// (RankHierarchy's distributed-mesh constructor), its clamp and its loads from its own cells; the
// coarse mesh is freed once distributed. solve_on_ranks() solves it with petsc-mgpcg's PETSc
// solver and reports the answer's invariants (compliance, largest displacement), the true
// residual, each stage's time and each rank's memory.
//
// The clamp and loads mean what they mean for a serial scene (pmg/sim/setup.hpp): the vertices
// within clamp_fraction of the extent from the minimum of clamp_axis (plus 1e-9 of the bounding
// box's largest extent) are clamped; gravity ρ g on every element; end_force spread as a uniform
// traction over the boundary faces at the maximum of clamp_axis; symmetry planes and supports hold
// components on planes of the bounding box (each must hold a planar part of the boundary). The
// bounding box is reduced over the ranks.
//
// Refinement: PETSc's regular refinement (DMRefine), which cuts each inner octahedron along a
// fixed diagonal; the serial route's mesh refinement (fem::refine_uniform) cuts it along the
// shortest. The vertices are the same, the inner tetrahedra may differ.
#pragma once

#include "pmg/distributed/mgpcg.hpp"
#include "pmg/distributed/rank_hierarchy.hpp"
#include "pmg/fem/mesh.hpp"
#include "pmg/sparse/monitor.hpp"

#include <mpi.h>

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace pmg::petsc {
class PlexMesh;
class GhostExchange;
}

namespace pmg::dist {

/// A plane of the bounding box on which components are held at zero: a symmetry plane (the normal
/// component) or a support (any components), as a serial scene's "symmetry" and "supports".
struct HeldPlane {
  int axis = 0;         ///< 0, 1, 2: the plane's normal
  bool at_max = false;  ///< the maximum of the axis (else the minimum)
  int components = 1;   ///< bits 1, 2, 4 for x, y, z (a symmetry plane: 1 << axis)
};

/// What MeshProblem builds (see the file comment).
struct MeshProblemOptions {
  int refine = 0;                        ///< uniform refinements after distribution (8x cells each)
  /// "auto": METIS (pmg::metis, on rank 0, the same partition every run) for a coarse mesh made on
  /// rank 0, PT-Scotch through PETSc for a mesh read in parallel (its parallel algorithms may
  /// partition differently from run to run); or "metis", "ptscotch", "simple" (PETSc's contiguous
  /// blocks).
  std::string partitioner = "auto";
  int degree = 2;                        ///< finest degree, 2 or 3 (the hierarchy holds 1 to it)
  fem::Material material;                ///< E, ν, ρ
  int clamp_axis = 0;                    ///< 0, 1, 2: the axis whose minimum is clamped (-1: free_body)
  /// No clamp (clamp_axis -1): a body free to move rigidly, for time steps only (the mass keeps
  /// each step's system definite; a static solve of it is singular).
  bool free_body = false;
  double clamp_fraction = 0.0;           ///< of the extent along clamp_axis, in [0, 1)
  fem::Vec3 gravity = fem::Vec3::Zero();    ///< m/s²
  fem::Vec3 end_force = fem::Vec3::Zero();  ///< total force on the far face (N)
  /// Components held on planes of the bounding box, each vertex within 1e-9 of the box's largest
  /// extent of a plane taking its bits (fem::DegreeHierarchy's rule then gives the nodes theirs).
  std::vector<HeldPlane> held;
  /// A stiffer (or softer) inclusion, as a serial scene's material.inclusion: the cells whose
  /// centroid lies in [inclusion_min, inclusion_max] get Young's modulus inclusion_young.
  bool inclusion = false;
  fem::Vec3 inclusion_min = fem::Vec3::Zero();  ///< lower corner of the inclusion's box
  fem::Vec3 inclusion_max = fem::Vec3::Zero();  ///< upper corner of the inclusion's box
  double inclusion_young = 0.0;                 ///< the inclusion's Young's modulus (Pa, > 0)
  /// Where non-empty: the distributed mesh, after refinement, written there in PETSc's HDF5
  /// format (pmg::petsc::PlexMesh::save), to be read in parallel by the file constructor.
  std::string save_mesh;
};

/// One rank's part of a distributed static problem (see the file comment).
class MeshProblem {
 public:
  /// `coarse` is called on rank 0 only and returns the mesh to distribute (a box, a file); it may
  /// throw, and its exception becomes every rank's. Collective; throws InputError for bad options,
  /// a clamp that holds nothing, an end force without a face to load.
  MeshProblem(MPI_Comm comm, const std::function<fem::TetMesh()>& coarse, const MeshProblemOptions& options);
  /// The same from a mesh in PETSc's HDF5 format (`.h5`, what options.save_mesh writes), read in
  /// parallel: every rank reads a share of the cells, then PT-Scotch repartitions them. Collective;
  /// throws InputError for a file that cannot be read as a tetrahedral mesh.
  MeshProblem(MPI_Comm comm, const std::string& plex_file, const MeshProblemOptions& options);
  ~MeshProblem();
  MeshProblem(const MeshProblem&) = delete;
  MeshProblem& operator=(const MeshProblem&) = delete;

  /// The rank's share of the hierarchy.
  RankHierarchy& ranks() { return *ranks_; }
  /// The rank's share of the hierarchy.
  const RankHierarchy& ranks() const { return *ranks_; }
  /// The external force on the finest level's owned unknowns (global order).
  const Vector& load() const { return load_; }
  /// Cells of all ranks (after refinement).
  long global_cells() const { return cells_; }
  /// Clamped vertices of all ranks.
  long clamped_vertices() const { return clamped_; }
  /// Components held by symmetry planes and supports on the finest level, all ranks (each held
  /// component of an owned node once).
  long held_components() const { return held_; }
  /// Cells of the inclusion, all ranks (0 without one).
  long inclusion_cells() const { return inclusion_cells_; }
  /// Lower corner of the bounding box (all ranks).
  const fem::Vec3& lo() const { return lo_; }
  /// Upper corner of the bounding box (all ranks).
  const fem::Vec3& hi() const { return hi_; }
  /// The force F spread as a uniform traction over the boundary faces at the maximum of the clamp
  /// axis (total force F, the serial scene's end_force), on the finest level's owned unknowns.
  /// Collective; throws InputError on every rank when no rank has such a face.
  Vector end_traction(const fem::Vec3& F) const;
  /// The mesh vertex of every rank whose key is the smallest (keys compared in order: a distance,
  /// then tie-breaks); every rank gets it. Collective.
  fem::Vec3 vertex_with_smallest(const std::function<std::array<double, 4>(const fem::Vec3&)>& key) const;
  /// Seconds of each stage on this rank, in order.
  const std::vector<std::pair<std::string, double>>& stages() const { return stages_; }
  /// This rank's peak resident memory (bytes, peak_resident_bytes()) at the end of each stage.
  const std::vector<double>& stage_peaks() const { return peaks_; }

 private:
  void check(const MeshProblemOptions& o) const;
  /// Refuses a held plane without boundary faces (every rank alike); counts the held components.
  void check_held(const MeshProblemOptions& o);
  void build(std::unique_ptr<petsc::PlexMesh> plex, const MeshProblemOptions& o, const std::vector<int>* parts);
  MPI_Comm comm_;
  std::unique_ptr<RankHierarchy> ranks_;
  std::unique_ptr<petsc::GhostExchange> exchange_;  // the finest level's
  int axis_ = 0;
  double tol_ = 0.0;  // of a position on the clamp and the far face
  Vector load_;
  long cells_ = 0, clamped_ = 0, held_ = 0, inclusion_cells_ = 0;
  /// The per-cell stiffness factors of o's inclusion on the rank's cells (empty: none).
  std::vector<double> inclusion_scale(const petsc::PlexMesh& plex, const MeshProblemOptions& o);
  fem::Vec3 lo_, hi_;
  std::vector<std::pair<std::string, double>> stages_;
  std::vector<double> peaks_;
};

/// What solve_on_ranks() measured; every figure is the same on every rank.
struct RankSolveReport {
  SolveResult result;              ///< iterations, reason, the solver's residual
  double true_residual = 0.0;      ///< ||b - A x|| / ||b|| with the finest shell operator
  double compliance = 0.0;         ///< bᵀx: the external work, independent of the numbering
  double max_displacement = 0.0;   ///< max over nodes of |x_node|
  long unknowns = 0;               ///< finest level, all ranks
  double setup_seconds = 0.0;      ///< the solver's set-up, the slowest rank's
  double solve_seconds = 0.0;      ///< the solve, the slowest rank's
  double peak_after_setup = 0.0;   ///< this rank's peak resident memory (bytes) after the solver's set-up
  double peak_after_solve = 0.0;   ///< and after the solve
  /// ||r_i|| / ||b|| per CG iteration and the seconds since the solve began (every rank alike).
  std::vector<IterationRecord> history;
  TimingBreakdown setup_stages;    ///< the solver's set-up by stage (this rank)
  std::string description;         ///< the solver's levels and lowest level
  /// Per level (finest first) and rank: (ghost nodes, owned nodes).
  std::vector<std::vector<std::pair<long, long>>> ghosts;
};

/// Solves the problem from zero with petsc-mgpcg's PETSc solver (CG + PCMG); x gets the owned
/// unknowns. Collective; a failed solve throws SolveError when params.throw_on_failure.
RankSolveReport solve_on_ranks(MeshProblem& problem, const DistributedMgpcgParams& params, Vector& x);

/// The peak resident memory of this process so far, in bytes (getrusage).
double peak_resident_bytes();

/// Whether `path` names a mesh in PETSc's HDF5 format (what the file constructor reads and
/// MeshProblemOptions::save_mesh writes): a name ending in ".h5".
bool is_plex_file(const std::string& path);

}  // namespace pmg::dist
