#include "scene.hpp"

#include "pmg/fem/generators.hpp"
#include "pmg/fem/mesh_io.hpp"
#include "pmg/multigrid/boomeramg.hpp"

#include <algorithm>
#include <chrono>
#include <iostream>
#include <sstream>

namespace pmg::tools {

void add_scene_options(CLI::App* sub, SceneOptions& o) {
  sub->add_option("--mesh", o.mesh, "tetrahedral mesh (.msh, .node/.ele) instead of the box bar")
      ->check(CLI::ExistingFile);
  sub->add_option("--box", o.box, "box bar: boxes of 24 tets along x y z")->expected(3)->capture_default_str();
  sub->add_option("--size", o.size, "box bar: side lengths [m]")->expected(3)->capture_default_str();
  sub->add_option("-p,--degree", o.degree, "element degree")->check(CLI::Range(1, 3))->capture_default_str();
  sub->add_option("--young", o.young, "Young's modulus [Pa]")->capture_default_str();
  sub->add_option("--poisson", o.poisson, "Poisson's ratio")->capture_default_str();
  sub->add_option("--density", o.density, "density [kg/m^3]")->capture_default_str();
  sub->add_option("--fix", o.fix, "clamp the minimum face of this axis")
      ->check(CLI::IsMember({"x", "y", "z"}))
      ->capture_default_str();
  sub->add_option("--fix-fraction", o.fix_fraction,
                  "clamp nodes within this fraction of the extent from that face (meshes of curved "
                  "shapes need > 0)")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  sub->add_option("--load", o.load, "traction: 10 N (-z) on the opposite face; gravity: 9.81 m/s^2 (-z)")
      ->check(CLI::IsMember({"traction", "gravity"}))
      ->capture_default_str();
  sub->add_option("--dt", o.dt, "> 0: the implicit-Euler system M + dt^2 K of one time step")
      ->check(CLI::NonNegativeNumber);
}

double start_mpi_for_hypre(const Config& config) {
  bool hypre = false;
  for (const auto& kv : config.items()) hypre |= kv.second.rfind("boomeramg", 0) == 0;
  if (!hypre) return -1.0;
  const auto t0 = std::chrono::steady_clock::now();
  mg::mpi_size();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double FemSystem::assemble_lower_levels() {
  const auto t0 = std::chrono::steady_clock::now();
  for (int l = 0; l + 1 < hierarchy->num_levels(); ++l)
    hierarchy->assemble_level(l, nullptr, nullptr, mass_weight, stiffness_weight);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

fem::TetMesh load_mesh_or_box(const std::string& file, const int box[3], const double size[3]) {
  if (file.empty()) return fem::box_mesh_24(box[0], box[1], box[2], size[0], size[1], size[2]);
  std::vector<std::string> warnings;
  fem::TetMesh mesh = fem::read_mesh(file, &warnings);
  for (const auto& w : warnings) std::cerr << "warning: " << w << "\n";
  return mesh;
}

FemSystem build_fem_system(const SceneOptions& o) {
  FemSystem s;
  s.mesh = load_mesh_or_box(o.mesh, o.box.data(), o.size.data());
  if (!o.mesh.empty()) {
    s.description = o.mesh;
  } else {
    s.description = "box bar " + std::to_string(o.box[0]) + "x" + std::to_string(o.box[1]) + "x" +
                    std::to_string(o.box[2]) + " boxes";
  }
  const int axis = o.fix[0] - 'x';
  double lo = 1e300, hi = -1e300;
  for (const auto& v : s.mesh.vertices) lo = std::min(lo, v[axis]), hi = std::max(hi, v[axis]);
  const double tol = 1e-9 * (hi - lo), limit = lo + o.fix_fraction * (hi - lo) + tol;
  s.hierarchy = std::make_unique<fem::DegreeHierarchy>(
      s.mesh, o.degree, fem::Material{o.young, o.poisson, o.density},
      [axis, limit](const fem::Vec3& X) { return X[axis] <= limit; });
  const fem::ElasticityModel& m = s.hierarchy->finest();
  const std::vector<char>& clamped = s.hierarchy->clamped_vertices();
  const int dim = fem::clamped_dimension(s.mesh, clamped);
  if (dim < 2) {
    std::ostringstream msg;
    msg << "scene: the clamped vertices (" << std::count(clamped.begin(), clamped.end(), 1)
        << " within --fix-fraction " << o.fix_fraction << " of the minimum " << o.fix << ") "
        << (dim < 0 ? "are none" : dim == 0 ? "are a single point" : "lie on one line")
        << ": the body could still move rigidly; raise --fix-fraction";
    throw InputError(msg.str());
  }
  Vector f = Vector::Zero(m.num_dofs());
  if (o.load == "gravity") {
    f = m.gravity(fem::Vec3(0, 0, -9.81));
  } else {
    const double area = m.add_traction(f, [axis, hi, tol](const fem::Vec3& X) { return X[axis] >= hi - tol; },
                                       fem::Vec3(0, 0, -1.0));
    if (!(area > 0)) throw InputError("scene: no boundary face at the maximum of axis " + o.fix);
    f *= 10.0 / area;  // 10 N in total
  }
  if (o.dt > 0) {
    s.mass_weight = 1.0;
    s.stiffness_weight = o.dt * o.dt;
    f *= o.dt;
  }
  s.b = m.restrict_to_free(f);
  const auto t0 = std::chrono::steady_clock::now();
  s.hierarchy->assemble_level(o.degree - 1, nullptr, nullptr, s.mass_weight, s.stiffness_weight);
  s.finest_assembly = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.description += ", degree " + std::to_string(o.degree) + ", " + std::to_string(s.mesh.num_tets()) +
                   " tets, " + std::to_string(m.num_fixed()) + " clamped nodes, " + o.load +
                   (o.dt > 0 ? ", M + dt^2 K with dt = " + std::to_string(o.dt) : ", static K");
  return s;
}

}  // namespace pmg::tools
