// pmg/distributed/scene.hpp — a simulation scene (pmg/sim/scene.hpp) as a static problem on a mesh
// no rank holds whole (pmg/distributed/mesh_problem.hpp): what `pmg compare --distributed-mesh`
// and pmgkit.solve_distributed build. Header-only, for callers that link pmg::sim beside
// pmg::distributed (pmg::distributed itself does not depend on pmg::sim).
#pragma once

#include "pmg/distributed/mesh_problem.hpp"
#include "pmg/sim/scene.hpp"
#include "pmg/sim/setup.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg::dist {

/// The scene's mesh refinement, degree, material (with its inclusion), clamp, supports and
/// symmetry planes and loads.
inline MeshProblemOptions mesh_problem_options(const sim::Scene& s) {
  MeshProblemOptions o;
  o.refine = s.refine;
  o.degree = s.degree;
  o.material = fem::Material{s.young, s.poisson, s.density};
  o.clamp_axis = s.clamp_axis;
  o.clamp_fraction = s.clamp_fraction;
  o.gravity = s.gravity;
  o.end_force = s.end_force;
  for (const sim::Scene::Support& sup : s.supports) o.held.push_back({sup.axis, sup.at_max, sup.components});
  o.inclusion = s.inclusion;
  o.inclusion_min = s.inclusion_min, o.inclusion_max = s.inclusion_max;
  o.inclusion_young = s.inclusion_young;
  return o;
}

/// The scene's problem on the ranks of `comm`: a mesh file in PETSc's HDF5 format read in parallel,
/// any other mesh file or the box bar made on rank 0 (its reader's warnings appended to
/// `warnings` there; `coarse_cells`, where given, gets its cell count on every rank, 0 for a
/// parallel read). Collective.
inline std::unique_ptr<MeshProblem> mesh_problem(MPI_Comm comm, const sim::Scene& s, const MeshProblemOptions& o,
                                                 std::vector<std::string>* warnings = nullptr,
                                                 long* coarse_cells = nullptr) {
  if (coarse_cells) *coarse_cells = 0;
  if (is_plex_file(s.mesh_file)) return std::make_unique<MeshProblem>(comm, s.mesh_file, o);
  long cells = 0;
  const auto coarse = [&] {
    fem::TetMesh m = sim::load_mesh_or_box(s.mesh_file, s.box.data(), s.size.data(), warnings, s.mesh_checks);
    cells = m.num_tets();
    return m;
  };
  auto problem = std::make_unique<MeshProblem>(comm, coarse, o);
  MPI_Bcast(&cells, 1, MPI_LONG, 0, comm);
  if (coarse_cells) *coarse_cells = cells;
  return problem;
}

}  // namespace pmg::dist
