#include "pmg/sim/setup.hpp"
#include "pmg/fem/mixed.hpp"
#include "pmg/sparse/defaults.hpp"

#include "pmg/fem/generators.hpp"
#include "pmg/fem/mesh_io.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/solvers.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/timer.hpp"
#ifdef PMG_HAVE_DISTRIBUTED
#include "text.hpp"

#include "pmg/distributed/scene.hpp"
#include "pmg/mpi/session.hpp"
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <tuple>

namespace pmg::sim {

using detail::fixed;

fem::TetMesh load_mesh_or_box(const std::string& file, const int box[3], const double size[3],
                              std::vector<std::string>* warnings, const fem::MeshCheckOptions& mesh_checks) {
  if (file.empty()) return fem::box_mesh_24(box[0], box[1], box[2], size[0], size[1], size[2]);
  std::vector<std::string> w;
  fem::TetMesh mesh = fem::read_mesh(file, &w, mesh_checks);
  if (warnings) warnings->insert(warnings->end(), w.begin(), w.end());
  // A file's element order (TetGen's, Gmsh's) scatters neighbours; the box generator's is local.
  return fem::reorder_for_locality(mesh);
}

fem::Vec3 Probe::displacement(const fem::ElasticityModel& m, const Vector& u) const {
  if (vertex >= 0) return u.segment<3>(3 * vertex);  // node v = vertex v on every degree
  return m.displacement_at(u, element, barycentric);
}

Vector end_force(const fem::ElasticityModel& m, int axis, double hi, double tol, const fem::Vec3& F) {
  Vector f = Vector::Zero(m.num_dofs());
  const double area = m.add_traction(f, [=](const fem::Vec3& X) { return X[axis] >= hi - tol; }, F);
  if (!(area > 0)) throw InputError("scene: no boundary face at the maximum of the clamp axis to load");
  return f / area;  // the traction F/area on each face: total force F
}

double estimated_memory_bytes(double tets, int degree, bool finest_assembled) {
  static constexpr double kBytesPerTet[] = {0.0, 2e3, 10e3, 50e3};
  static constexpr double kMatrixFreeBytesPerTet[] = {0.0, 2e3, 1.5e3, 4e3};  // degree 1 is assembled
  const int p = std::clamp(degree, 1, 3);
  return tets * (finest_assembled ? kBytesPerTet[p] : kMatrixFreeBytesPerTet[p]);
}

namespace {
/// Refuses, before anything is built, a scene whose element count overflows the index type or
/// whose memory estimate exceeds the machine's.
void check_size(double tets, const Scene& s, bool finest_assembled) {
  char what[160];
  std::snprintf(what, sizeof what, "scene: %.3g tetrahedra of degree %d%s", tets, s.degree,
                s.refine > 0 ? " (after mesh.refine)" : "");
  if (tets > 2e9) throw InputError(std::string(what) + ": more elements than a 32-bit index can number");
  require_memory(estimated_memory_bytes(tets, s.degree, finest_assembled), what);
}
}  // namespace

SceneSetup set_up(const Scene& s, bool finest_assembled) {
  SceneSetup b;
  if (!s.formulation_choice.empty()) b.notes.push_back(s.formulation_choice);
  auto t0 = Clock::now();
  auto stage = [&](const char* name) {  // the seconds since the previous stage's end
    b.stages.emplace_back(name, seconds_since(t0));
    t0 = Clock::now();
  };
  // The box's size is known before it is generated; a file's once it is read.
  const double refined = std::pow(8.0, s.refine);
  if (s.mesh_file.empty()) check_size(24.0 * s.box[0] * s.box[1] * s.box[2] * refined, s, finest_assembled);
  fem::TetMesh loaded = load_mesh_or_box(s.mesh_file, s.box.data(), s.size.data(), &b.warnings, s.mesh_checks);
  if (!s.mesh_file.empty()) check_size(loaded.num_tets() * refined, s, finest_assembled);
  stage(s.mesh_file.empty() ? "mesh (box)" : "mesh (read)");
  std::vector<fem::Refinement> refinements;
  b.mesh = std::make_unique<const fem::TetMesh>(fem::refine_uniform(loaded, s.refine, &refinements));
  if (s.refine > 0) stage("refinement");
  const fem::TetMesh& mesh = *b.mesh;
  b.lo = fem::Vec3::Constant(1e300), b.hi = fem::Vec3::Constant(-1e300);
  for (const auto& v : mesh.vertices) b.lo = b.lo.cwiseMin(v), b.hi = b.hi.cwiseMax(v);
  b.centre = 0.5 * (b.lo + b.hi);
  const int axis = s.clamp_axis;
  const double extent = (b.hi - b.lo).maxCoeff(), tol = 1e-9 * extent;
  const double limit = axis >= 0 ? b.lo[axis] + s.clamp_fraction * (b.hi[axis] - b.lo[axis]) + tol : -1e300;
  // Supports and symmetry planes: per vertex, the components held (bits 1, 2, 4).
  std::vector<char> held;
  if (!s.supports.empty()) {
    held.assign(mesh.vertices.size(), 0);
    for (const auto& sup : s.supports) {
      const double face = sup.at_max ? b.hi[sup.axis] : b.lo[sup.axis];
      for (size_t v = 0; v < held.size(); ++v)
        if (std::abs(mesh.vertices[v][sup.axis] - face) <= tol) held[v] = static_cast<char>(held[v] | sup.components);
    }
  }
  // A mixed scene's displacement levels carry the shear material (E' = 2μ, ν' = 0; pmg/fem/mixed.hpp).
  const fem::Material material{s.young, s.poisson, s.density};
  b.hierarchy = std::make_unique<fem::DegreeHierarchy>(
      mesh, s.degree, s.formulation == "mixed" ? fem::MixedElasticity::shear_material(material) : material,
      [axis, limit](const fem::Vec3& X) { return axis >= 0 && X[axis] <= limit; }, std::move(held));
  b.hierarchy->set_refinements(refinements);  // the coarser meshes' linear levels (coarse_meshes)
  stage("degree hierarchy");
  // Each support must hold a planar part of the boundary, not a point or a line where a curved
  // surface touches its bounding box: the area of the boundary faces whose three vertices lie on it.
  for (const auto& sup : s.supports) {
    const double face = sup.at_max ? b.hi[sup.axis] : b.lo[sup.axis];
    Vector scratch = Vector::Zero(b.hierarchy->finest().num_dofs());
    const double area = b.hierarchy->finest().add_traction(
        scratch, [&](const fem::Vec3& X) { return std::abs(X[sup.axis] - face) <= tol; }, fem::Vec3::Zero());
    const std::string where = std::string(sup.at_max ? "maximum" : "minimum") + " of " + static_cast<char>('x' + sup.axis);
    if (!(area > 0))
      throw InputError("scene: the support or symmetry plane at the " + where +
                       " holds no boundary face (the mesh touches that plane in points or lines only: a "
                       "symmetry plane needs a planar cut face)");
    std::ostringstream note;
    note << "support at the " << where << ": " << area << " m^2 of boundary faces";
    b.notes.push_back(note.str());
  }
  if (axis >= 0) {
    const std::vector<char>& clamped = b.hierarchy->clamped_vertices();
    const int dim = fem::clamped_dimension(mesh, clamped);
    if (dim < 2) {
      std::ostringstream msg;
      msg << "scene: the clamped vertices (" << std::count(clamped.begin(), clamped.end(), 1) << " within fraction "
          << s.clamp_fraction << " of the minimum of " << static_cast<char>('x' + axis) << ") "
          << (dim < 0 ? "are none" : dim == 0 ? "are a single point" : "lie on one line")
          << ": the body could still move rigidly; clamp a larger fraction (scene clamp.fraction, "
             "pmg compare --fix-fraction)";
      throw InputError(msg.str());
    }
  }
  if (s.inclusion) {
    std::vector<double> scale(mesh.num_tets(), 1.0);
    index_t inside = 0;
    for (index_t e = 0; e < mesh.num_tets(); ++e) {
      fem::Vec3 c = fem::Vec3::Zero();
      for (index_t v : mesh.tets[e]) c += 0.25 * mesh.vertices[v];
      if ((c.array() >= s.inclusion_min.array()).all() && (c.array() <= s.inclusion_max.array()).all())
        scale[e] = s.inclusion_young / s.young, ++inside;
    }
    if (inside == 0) throw InputError("material.inclusion: no element centroid lies inside [min, max]");
    b.hierarchy->set_stiffness_scale(scale);
    std::ostringstream note;
    note << "material: inclusion of " << inside << " elements with E = " << s.inclusion_young << " Pa (contrast "
         << s.inclusion_young / s.young << ")";
    b.notes.push_back(note.str());
  }
  stage("supports, clamp and inclusion");
  const fem::ElasticityModel& m = b.hierarchy->finest();
  b.f_ext = Vector::Zero(m.num_dofs());
  if (s.gravity.norm() > 0) b.f_ext += m.gravity(s.gravity);
  else b.notes.push_back("gravity load: skipped (none in the scene)");
  if (s.end_force.norm() > 0) {
    if (axis < 0) throw InputError("loads.end_force: needs a clamp axis (it loads the far face)");
    b.f_ext += end_force(m, axis, b.hi[axis], tol, s.end_force);
  }
  Probe& p = b.probe;
  if (s.probe) {
    p.point = *s.probe;
    try {
      std::tie(p.element, p.barycentric) = m.locate(p.point);  // once, not per step
    } catch (const Error&) {
      throw InputError("output.probe: the point lies outside the mesh");
    }
  } else {
    std::array<double, 4> best;
    best.fill(1e300);
    for (index_t v = 0; v < static_cast<index_t>(mesh.vertices.size()); ++v) {
      const std::array<double, 4> k = probe_key(s, b.lo, b.hi, mesh.vertices[v]);
      if (k < best) best = k, p.vertex = v;
    }
    p.point = mesh.vertices[p.vertex];
  }
  stage("loads and probe");
  return b;
}

std::array<double, 4> probe_key(const Scene& s, const fem::Vec3& lo, const fem::Vec3& hi, const fem::Vec3& X) {
  const fem::Vec3 centre = 0.5 * (lo + hi);
  const int axis = s.clamp_axis;
  if (axis < 0) return {-(X - centre).norm(), X[0], X[1], X[2]};
  fem::Vec3 target = centre;
  target[axis] = hi[axis];
  return {(X - target).norm(), -X[axis], X[(axis + 1) % 3], X[(axis + 2) % 3]};
}

SceneSetup set_up_on_ranks(const Scene& s) {
#ifdef PMG_HAVE_DISTRIBUTED
  SceneSetup b;
  mpi::start();
  MPI_Comm comm = MPI_COMM_WORLD;
  dist::MeshProblemOptions o = dist::mesh_problem_options(s);
  o.free_body = s.dynamic && s.clamp_axis < 0;  // a free body steps: its mass keeps each system definite
  if (!s.dynamic && s.density == 0) {
    // A static scene may have no density: its gravity load ρ g is zero, and no mass is used. The
    // ranks' models take density 1 (what a time-step object checks) without a gravity load.
    o.material.density = 1.0;
    o.gravity = fem::Vec3::Zero();
  }
  b.on_ranks = dist::mesh_problem(comm, s, o, &b.warnings, &b.rank_mesh.coarse_cells);
  const dist::MeshProblem& p = *b.on_ranks;
  const dist::RankHierarchy& R = p.ranks();
  const int top = R.num_levels() - 1;
  RankMeshSummary& r = b.rank_mesh;
  r.ranks = R.size();
  r.cells = p.global_cells();
  r.unknowns = 3 * static_cast<long>(R.global_nodes(top));
  r.clamped_vertices = p.clamped_vertices();
  r.stages = p.stages();
  b.lo = p.lo(), b.hi = p.hi(), b.centre = 0.5 * (b.lo + b.hi);
  if (s.probe) b.probe.point = *s.probe;
  else b.probe.point = p.vertex_with_smallest([&](const fem::Vec3& X) { return probe_key(s, b.lo, b.hi, X); });
  if (s.gravity.norm() == 0) b.notes.push_back("gravity load: skipped (none in the scene)");
  return b;
#else
  (void)s;
  throw InputError("a scene on a distributed mesh: this build has no PETSc (pmg::distributed is not built)");
#endif
}

std::pair<Vector, Vector> formula_state(const Scene& s, const fem::ElasticityModel& m, const fem::Vec3& lo_corner,
                                        const fem::Vec3& hi_corner) {
  Vector u = Vector::Zero(m.num_dofs()), v = Vector::Zero(m.num_dofs());
  const int axis = s.clamp_axis;
  const fem::Vec3 centre = 0.5 * (lo_corner + hi_corner);
  const double lo = axis >= 0 ? lo_corner[axis] : 0.0, L = axis >= 0 ? hi_corner[axis] - lo : 0.0;
  if (s.initial != "rest" && s.initial != "spinning" && axis < 0)
    throw InputError("initial.state " + s.initial + ": needs a clamp axis");
  if (s.initial == "compressed") {
    u = m.interpolate([&](const fem::Vec3& X) {
      fem::Vec3 d = fem::Vec3::Zero();
      d[axis] = -s.strain * (X[axis] - lo);
      return d;
    });
  } else if (s.initial == "twisted") {
    const double total = s.twist_degrees * M_PI / 180.0;
    u = m.interpolate([&](const fem::Vec3& X) {
      const double a = total * (X[axis] - lo) / L;
      const int i = (axis + 1) % 3, j = (axis + 2) % 3;
      const double yi = X[i] - centre[i], yj = X[j] - centre[j];
      fem::Vec3 d = fem::Vec3::Zero();
      d[i] = std::cos(a) * yi - std::sin(a) * yj - yi;
      d[j] = std::sin(a) * yi + std::cos(a) * yj - yj;
      return d;
    });
  } else if (s.initial == "spinning") {
    v = m.interpolate([&](const fem::Vec3& X) -> fem::Vec3 { return s.omega.cross(X - centre); });
  }
  for (index_t i = 0; i < m.num_nodes(); ++i)
    if (m.is_fixed(i)) u.segment<3>(3 * i).setZero(), v.segment<3>(3 * i).setZero();
  return {u, v};
}

std::pair<Vector, Vector> initial_state(const Scene& s, SceneSetup& b) {
  const fem::ElasticityModel& m = b.finest();
  auto [u, v] = formula_state(s, m, b.lo, b.hi);
  if (s.initial == "deflected") {
    const auto t0 = Clock::now();
    const int axis = s.clamp_axis;
    const Vector f = end_force(m, axis, b.hi[axis], 1e-9 * (b.hi[axis] - b.lo[axis]), s.initial_force);
    fem::StaticOptions so;
    so.corotational_tol = 1e-6;
    register_all_solvers();  // the static solve's default direct method
    const fem::StaticResult r = fem::solve_static(m, f, s.corotational, so);
    u = r.u;
    b.notes.push_back("initial state: static deflection under the end force, " +
                      std::to_string(r.iterations) + " fixed-point iterations, " + fixed(seconds_since(t0), 2) + " s");
  }
  return {u, v};
}

std::unique_ptr<Solver> make_step_solver(const Scene& s, const fem::DegreeHierarchy& h,
                                         std::string& method, std::string& settings,
                                         std::vector<std::string>& notes) {
  Config c = s.solver.clone();  // every Scene's solver options were completed by the registry
  method = c.get_string("method", kDefaultDynamicMethod);
  if (method_uses_levels(method) && h.num_levels() < 2) {
    notes.push_back("multigrid: skipped (degree 1 has no lower degree; CHOLMOD solves each step)");
    c = Config::from_pairs({std::string("method=") + kDefaultDirectMethod}, c.origin());
    method = kDefaultDirectMethod;
  }
  // Warm-started steps end at once when the start is within rounding of the solution.
  if (method_accepts_key(method, "rhs_floor")) c.set_default("rhs_floor", "1e-12");
  SolverContext ctx;
  ctx.levels = &h;
  auto solver = make_solver(c, ctx, kDefaultDynamicMethod);
  const double start = start_libraries(c);  // MPI, PETSc: once per process, not a step's cost
  if (start >= 0) notes.push_back("MPI (and PETSc) start-up: " + fixed(start, 3) + " s");
  settings = c.to_string();
  return solver;
}

}  // namespace pmg::sim
