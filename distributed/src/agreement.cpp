#include "agreement.hpp"

#include <cstdio>
#include <cstdlib>

namespace pmg::dist::detail {

std::string exact(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::vector<mpi::Item> hierarchy_items(const fem::DegreeHierarchy& h) {
  const fem::ElasticityModel& m = h.finest();
  const fem::TetMesh& mesh = m.space().mesh();
  std::vector<char> fixed(static_cast<size_t>(m.num_nodes()));
  for (index_t i = 0; i < m.num_nodes(); ++i) fixed[static_cast<size_t>(i)] = m.is_fixed(i) ? 1 : 0;
  const auto& scale = m.stiffness_scale();
  return {
      {"the degree", std::to_string(m.space().degree())},
      {"the number of levels", std::to_string(h.num_levels())},
      {"the mesh's vertices", std::to_string(mesh.num_vertices()) + " vertices, digest " +
                                  mpi::digest(mesh.vertices.data(), mesh.vertices.size() * sizeof(mesh.vertices[0]))},
      {"the mesh's elements", std::to_string(mesh.num_tets()) + " elements, digest " +
                                  mpi::digest(mesh.tets.data(), mesh.tets.size() * sizeof(mesh.tets[0]))},
      {"Young's modulus", exact(m.material().young)},
      {"Poisson's ratio", exact(m.material().poisson)},
      {"the density", exact(m.material().density)},
      {"the per-element stiffness", "digest " + mpi::digest(scale.data(), scale.size() * sizeof(double))},
      {"the fixed nodes", "digest " + mpi::digest(fixed.data(), fixed.size())},
      {"the held components", "digest " + mpi::digest(h.component_masks().data(), h.component_masks().size())},
  };
}

std::vector<mpi::Item> params_items(const DistributedMgpcgParams& p) {
  return {
      {"tol", exact(p.tol)},
      {"max_iterations", std::to_string(p.max_iterations)},
      {"rhs_floor", exact(p.rhs_floor)},
      {"throw_on_failure", p.throw_on_failure ? "true" : "false"},
      {"smoothing_steps", std::to_string(p.smoothing_steps)},
      {"lowest_level", p.lowest_level},
      {"options", p.options},
      {"unused_keys", p.allow_unused_options ? "known or ignore" : "error"},
      {"the environment's PETSC_OPTIONS", std::getenv("PETSC_OPTIONS") ? std::getenv("PETSC_OPTIONS") : ""},
  };
}

}  // namespace pmg::dist::detail
