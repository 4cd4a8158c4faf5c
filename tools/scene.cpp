#include "scene.hpp"

#include "checks.hpp"

#include "pmg/fem/simulation.hpp"
#include "pmg/sim/setup.hpp"
#include "pmg/sparse/timer.hpp"

#include <algorithm>
#include <chrono>
#include <iostream>
#include <sstream>

namespace pmg::tools {

SceneOptions::SceneOptions() {
  const sim::Scene bar = sim::table_bar();
  box.assign(bar.box.begin(), bar.box.end());
  size.assign(bar.size.begin(), bar.size.end());
  young = bar.young, poisson = bar.poisson, density = bar.density;
}

void add_scene_options(CLI::App* sub, SceneOptions& o) {
  sub->add_option("--mesh", o.mesh, "tetrahedral mesh (.msh, .node/.ele) instead of the box bar")
      ->check(CLI::ExistingFile);
  sub->add_option("--box", o.box, "box bar: boxes of 24 tets along x y z")
      ->expected(3)
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  sub->add_option("--size", o.size, "box bar: side lengths [m]")
      ->expected(3)
      ->check(FinitePositive())
      ->capture_default_str();
  sub->add_option("--refine", o.refine,
                  "refine the mesh uniformly this many times (8x elements each); with --distributed-mesh "
                  "on the ranks after distribution")
      ->check(CLI::Range(0, 6))
      ->capture_default_str();
  sub->add_option("-p,--degree", o.degree, "element degree")->check(CLI::Range(1, 3))->capture_default_str();
  sub->add_option("--young", o.young, "Young's modulus [Pa]")->check(FinitePositive())->capture_default_str();
  sub->add_option("--poisson", o.poisson, "Poisson's ratio (0.5: the mixed formulation only)")
      ->check(FiniteRange(-1.0, 0.5, true, false))
      ->capture_default_str();
  sub->add_option("--density", o.density, "density [kg/m^3]")->check(FiniteNonNegative())->capture_default_str();
  sub->add_option("--fix", o.fix, "clamp the minimum face of this axis")
      ->check(CLI::IsMember({"x", "y", "z"}))
      ->capture_default_str();
  sub->add_option("--fix-fraction", o.fix_fraction,
                  "clamp nodes within this fraction of the extent from that face (meshes of curved "
                  "shapes need > 0)")
      ->check(FiniteRange(0.0, 0.5))
      ->capture_default_str();
  sub->add_option("--load", o.load, "traction: 10 N (-z) on the opposite face; gravity: 9.81 m/s^2 (-z)")
      ->check(CLI::IsMember({"traction", "gravity"}))
      ->capture_default_str();
  sub->add_option("--symmetry", o.symmetry,
                  "symmetry planes: AXIS (its minimum face) or AXIS:max, each holding the normal "
                  "component of its nodes at zero (a half or quarter model)")
      ->check(CLI::IsMember({"x", "y", "z", "x:min", "y:min", "z:min", "x:max", "y:max", "z:max"}));
  sub->add_option("--dt", o.dt, "> 0: the implicit-Euler system M + dt^2 K of one time step")
      ->check(FiniteNonNegative());
  add_allow_option(sub, o.allow);
}

index_t held_components(const fem::ElasticityModel& m) {
  index_t n = 0;
  for (char c : m.constrained_free_dofs()) n += c;
  return n;
}

sim::Scene scene_of(const SceneOptions& o) {
  sim::Scene s = sim::table_bar();  // its end load unless gravity is asked for
  s.source = "pmg compare options";
  s.mesh_file = o.mesh;
  for (int d = 0; d < 3; ++d) s.box[d] = o.box[d], s.size[d] = o.size[d];
  s.degree = o.degree;
  s.refine = o.refine;
  s.young = o.young, s.poisson = o.poisson, s.density = o.density;
  s.clamp_axis = o.fix[0] - 'x';
  s.clamp_fraction = o.fix_fraction;
  if (o.load == "gravity") {
    s.gravity = fem::Vec3(0, 0, -9.81);
    s.end_force = fem::Vec3::Zero();
  }
  for (const auto& a : o.allow) fem::allow_mesh_defect(s.mesh_checks, a);
  for (const auto& plane : o.symmetry) {
    sim::Scene::Support sup;
    sup.axis = plane[0] - 'x';
    sup.at_max = plane.size() > 2 && plane.substr(2) == "max";
    sup.components = 1 << sup.axis;
    s.supports.push_back(sup);
  }
  s.dynamic = o.dt > 0;
  if (o.dt > 0) s.dt = o.dt;
  return s;
}

FemSystem build_fem_system(const SceneOptions& o, bool assemble_finest) {
  FemSystem s;
  static_cast<sim::SceneSystem&>(s) = sim::system_of(scene_of(o), o.dt, assemble_finest);
  for (const auto& w : s.setup.warnings) std::cerr << "warning: " << w << "\n";
  const fem::ElasticityModel& m = s.setup.finest();
  s.description = (o.mesh.empty() ? "box bar " + std::to_string(o.box[0]) + "x" + std::to_string(o.box[1]) + "x" +
                                        std::to_string(o.box[2]) + " boxes"
                                  : o.mesh) +
                  (o.refine > 0 ? ", refined " + std::to_string(o.refine) + "x" : "") + ", degree " + std::to_string(o.degree) + ", " + std::to_string(s.setup.mesh->num_tets()) +
                  " tets, " + std::to_string(m.num_fixed()) + " clamped nodes, " +
                  (o.symmetry.empty() ? "" : std::to_string(held_components(m)) + " components held by symmetry planes, ") +
                  o.load + (o.dt > 0 ? ", M + dt^2 K with dt = " + std::to_string(o.dt) : ", static K");
  return s;
}

}  // namespace pmg::tools
