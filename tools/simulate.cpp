// pmg simulate [scene.json]: a dynamic (or static) corotational simulation of a JSON scene; with
// no file, the built-in default scene (a cubic cantilever released from a deflected state).
#include "commands.hpp"
#include "scene.hpp"
#include "scene_file.hpp"
#include "table.hpp"

#include <nlohmann/json.hpp>

#include "pmg/fem/generators.hpp"
#include "pmg/fem/mesh_io.hpp"
#include "pmg/fem/simulation.hpp"
#include "pmg/multigrid/boomeramg.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/fem/vtk_writer.hpp"
#include "pmg/sparse/file_io.hpp"

#include <omp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <iostream>
#include <memory>
#include <sstream>

namespace pmg::tools {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

using json = nlohmann::json;

struct Cli {
  std::string scene, output, json_report;
  double duration = 0, dt = 0;
  bool print_scene = false, quiet = false;
  int threads = 0;
};

struct Built {
  fem::TetMesh mesh;
  std::unique_ptr<fem::DegreeHierarchy> h;
  Vector f_ext;
  double lo = 0, hi = 0;     // extent along the clamp axis
  fem::Vec3 centre;          // of the bounding box
  index_t probe_vertex = -1;  // -1: probe by location, in probe_element at probe_barycentric
  fem::Vec3 probe;
  index_t probe_element = -1;
  Eigen::Vector4d probe_barycentric;
  std::vector<std::string> notes;  // what was done once or skipped, for the report
};

void make_dir(const std::string& dir) {
  if (mkdir(dir.c_str(), 0777) != 0 && errno != EEXIST)
    throw InputError("output.directory: cannot create '" + dir + "'");
}

/// Force on the far face (maximum of the clamp axis) spread as a uniform traction.
Vector end_force(const fem::ElasticityModel& m, int axis, double hi, double tol, const fem::Vec3& F) {
  Vector f = Vector::Zero(m.num_dofs());
  const double area = m.add_traction(f, [=](const fem::Vec3& X) { return X[axis] >= hi - tol; }, F);
  if (!(area > 0)) throw InputError("scene: no boundary face at the maximum of the clamp axis to load");
  return f / area;  // the traction F/area on each face: total force F
}

Built build(const SimScene& s) {
  Built b;
  b.mesh = fem::refine_uniform(load_mesh_or_box(s.mesh_file, s.box.data(), s.size.data()), s.refine);
  fem::Vec3 lo = fem::Vec3::Constant(1e300), hi = fem::Vec3::Constant(-1e300);
  for (const auto& v : b.mesh.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  b.centre = 0.5 * (lo + hi);
  const int axis = s.clamp_axis;
  const double extent = (hi - lo).maxCoeff(), tol = 1e-9 * extent;
  if (axis >= 0) b.lo = lo[axis], b.hi = hi[axis];
  const double limit = axis >= 0 ? lo[axis] + s.clamp_fraction * (hi[axis] - lo[axis]) + tol : -1e300;
  b.h = std::make_unique<fem::DegreeHierarchy>(
      b.mesh, s.degree, fem::Material{s.young, s.poisson, s.density},
      [axis, limit](const fem::Vec3& X) { return axis >= 0 && X[axis] <= limit; });
  if (axis >= 0) {
    const int dim = fem::clamped_dimension(b.mesh, b.h->clamped_vertices());
    if (dim < 2)
      throw InputError("scene: clamp.fraction " + std::to_string(s.clamp_fraction) +
                       " clamps too few vertices (" + (dim < 0 ? "none" : dim == 0 ? "one point" : "all on one line") +
                       "): the body could still move rigidly");
  }
  if (s.inclusion) {
    std::vector<double> scale(b.mesh.num_tets(), 1.0);
    index_t inside = 0;
    for (index_t e = 0; e < b.mesh.num_tets(); ++e) {
      fem::Vec3 c = fem::Vec3::Zero();
      for (index_t v : b.mesh.tets[e]) c += 0.25 * b.mesh.vertices[v];
      if ((c.array() >= s.inclusion_min.array()).all() && (c.array() <= s.inclusion_max.array()).all())
        scale[e] = s.inclusion_young / s.young, ++inside;
    }
    if (inside == 0) throw InputError("material.inclusion: no element centroid lies inside [min, max]");
    b.h->set_stiffness_scale(scale);
    std::ostringstream note;
    note << "material: inclusion of " << inside << " elements with E = " << s.inclusion_young << " Pa (contrast "
         << s.inclusion_young / s.young << ")";
    b.notes.push_back(note.str());
  }
  const fem::ElasticityModel& m = b.h->finest();
  b.f_ext = Vector::Zero(m.num_dofs());
  if (s.gravity.norm() > 0) b.f_ext += m.gravity(s.gravity);
  else b.notes.push_back("gravity load: skipped (none in the scene)");
  if (s.end_force.norm() > 0) {
    if (axis < 0) throw InputError("loads.end_force: needs a clamp axis (it loads the far face)");
    b.f_ext += end_force(m, axis, hi[axis], tol, s.end_force);
  }
  // Probe: the given point, or the vertex nearest the centre of the far face (farthest from the
  // centre when nothing is clamped).
  if (s.probe) {
    b.probe = *s.probe;
    try {
      std::tie(b.probe_element, b.probe_barycentric) = m.locate(b.probe);  // once, not per step
    } catch (const Error&) {
      throw InputError("output.probe: the point lies outside the mesh");
    }
  } else {
    fem::Vec3 target = b.centre;
    if (axis >= 0) target[axis] = hi[axis];
    double best = 1e300;
    for (index_t v = 0; v < static_cast<index_t>(b.mesh.vertices.size()); ++v) {
      const double d = axis >= 0 ? (b.mesh.vertices[v] - target).norm() : -(b.mesh.vertices[v] - b.centre).norm();
      if (d < best) best = d, b.probe_vertex = v;
    }
    b.probe = b.mesh.vertices[b.probe_vertex];
  }
  return b;
}

json vec3(const fem::Vec3& v) { return {v.x(), v.y(), v.z()}; }

fem::Vec3 probe_displacement(const Built& b, const Vector& u) {
  if (b.probe_vertex >= 0) return u.segment<3>(3 * b.probe_vertex);  // node v = vertex v
  return b.h->finest().displacement_at(u, b.probe_element, b.probe_barycentric);
}

/// Initial displacement and velocity (full vectors; clamped nodes at rest).
std::pair<Vector, Vector> initial_state(const SimScene& s, Built& b) {
  const fem::ElasticityModel& m = b.h->finest();
  Vector u = Vector::Zero(m.num_dofs()), v = Vector::Zero(m.num_dofs());
  const int axis = s.clamp_axis;
  const double L = b.hi - b.lo;
  if (s.initial == "deflected") {
    const auto t0 = Clock::now();
    const double tol = 1e-9 * L;
    const Vector f = end_force(m, axis, b.hi, tol, s.initial_force);
    fem::StaticOptions so;
    so.corotational_tol = 1e-6;
    const fem::StaticResult r = fem::solve_static(m, f, s.corotational, so);
    u = r.u;
    b.notes.push_back("initial state: static deflection under the end force, " +
                      std::to_string(r.iterations) + " fixed-point iterations, " + fmt("%.2f", since(t0)) + " s");
  } else if (s.initial == "compressed") {
    u = m.interpolate([&](const fem::Vec3& X) {
      fem::Vec3 d = fem::Vec3::Zero();
      d[axis] = -s.strain * (X[axis] - b.lo);
      return d;
    });
  } else if (s.initial == "twisted") {
    const double total = s.twist_degrees * M_PI / 180.0;
    u = m.interpolate([&](const fem::Vec3& X) {
      const double a = total * (X[axis] - b.lo) / L;
      const int i = (axis + 1) % 3, j = (axis + 2) % 3;
      const double yi = X[i] - b.centre[i], yj = X[j] - b.centre[j];
      fem::Vec3 d = fem::Vec3::Zero();
      d[i] = std::cos(a) * yi - std::sin(a) * yj - yi;
      d[j] = std::sin(a) * yi + std::cos(a) * yj - yj;
      return d;
    });
  } else if (s.initial == "spinning") {
    v = m.interpolate([&](const fem::Vec3& X) -> fem::Vec3 { return s.omega.cross(X - b.centre); });
  }
  for (index_t i = 0; i < m.num_nodes(); ++i)
    if (m.is_fixed(i)) u.segment<3>(3 * i).setZero(), v.segment<3>(3 * i).setZero();
  return {u, v};
}

/// The step solver from the scene's solver options, through the one factory. Degree 1 has no
/// lower degree: a multigrid method falls back to CHOLMOD (with a note).
std::unique_ptr<Solver> make_step_solver(const SimScene& s, const fem::DegreeHierarchy& h,
                                         std::string& method, std::string& settings,
                                         std::vector<std::string>& notes) {
  Config c = s.solver.clone();
  method = c.get_string("method", "pmg");
  if (method_uses_levels(method) && h.num_levels() < 2) {
    notes.push_back("multigrid: skipped (degree 1 has no lower degree; CHOLMOD solves each step)");
    c = Config::from_pairs({"method=cholmod"}, c.origin());
    method = "cholmod";
  }
  // Warm-started steps end at once when the start is within rounding of the solution.
  if (method_accepts_key(method, "rhs_floor")) c.set_default("rhs_floor", "1e-12");
  const double mpi = start_mpi_for_hypre(c);  // once per process: not a step's cost
  if (mpi >= 0) notes.push_back("MPI start-up for hypre: " + fmt("%.3f", mpi) + " s");
  SolverContext ctx;
  ctx.levels = &h;
  auto solver = make_solver(c, ctx, "pmg");
  settings = c.to_string();
  return solver;
}

std::string frame_name(int step) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "frame_%06d.vtu", step);
  return buf;
}

class Progress {
 public:
  Progress(int total, bool quiet) : total_(total), quiet_(quiet), tty_(isatty(fileno(stdout))), t0_(Clock::now()) {}
  void update(int step, double t) {
    if (quiet_) return;
    const double elapsed = since(t0_);
    const double eta = step > 0 ? elapsed * (total_ - step) / step : 0.0;
    if (tty_) {
      const int width = 30, filled = static_cast<int>(width * static_cast<double>(step) / total_);
      std::printf("\r[%s%s] step %d/%d  t = %.3f s  elapsed %.1f s  ETA %.1f s ", std::string(filled, '#').c_str(),
                  std::string(width - filled, '.').c_str(), step, total_, t, elapsed, eta);
      if (step == total_) std::printf("\n");
      std::fflush(stdout);
    } else if (step == total_ || step * 10 / total_ != (step - 1) * 10 / total_) {
      std::printf("step %d/%d  t = %.3f s  elapsed %.1f s  ETA %.1f s\n", step, total_, t, elapsed, eta);
      std::fflush(stdout);
    }
  }
  void interrupt() {
    if (tty_ && !quiet_) std::printf("\n");
  }

 private:
  int total_;
  bool quiet_, tty_;
  Clock::time_point t0_;
};

void run_static(const SimScene& s, Built& b, const Cli& cli, json& report) {
  const fem::ElasticityModel& m = b.h->finest();
  const auto t0 = Clock::now();
  fem::StaticOptions so;
  so.corotational_tol = 1e-6;
  const fem::StaticResult r = fem::solve_static(m, b.f_ext, s.corotational, so);
  const double solve = since(t0);
  const fem::Vec3 d = probe_displacement(b, r.u);
  std::cout << "static solve (CHOLMOD" << (s.corotational ? ", corotational fixed point" : "") << "): "
            << r.iterations << " iteration(s), " << fmt("%.3f", solve) << " s\n"
            << "probe (" << b.probe.transpose() << ") displacement: " << d.transpose() << "\n"
            << "skipped: mass matrix, time loop (static scene)\n";
  report["static"] = {{"solver", "cholmod"}, {"iterations", r.iterations}, {"seconds", solve}};
  report["probe"] = {{"point_m", vec3(b.probe)}, {"displacement_m", vec3(d)}};
  if (!cli.output.empty()) {
    make_dir(cli.output);
    fem::write_vtu(cli.output + "/static.vtu", m.space(), r.u);
    std::cout << "wrote " << cli.output << "/static.vtu\n";
    report["outputs"] = {cli.output + "/static.vtu"};
  }
}

void run_dynamic(const SimScene& s, Built& b, const Cli& cli, json& report) {
  fem::ElasticityModel const& m = b.h->finest();
  std::vector<std::string>& notes = b.notes;
  const auto [u0, v0] = initial_state(s, b);
  std::string method, settings;
  auto solver = make_step_solver(s, *b.h, method, settings, notes);
  fem::SimulationParams sp;
  sp.dt = s.dt;
  sp.rayleigh_alpha = s.rayleigh_alpha;
  sp.rayleigh_beta = s.rayleigh_beta;
  sp.corotational = s.corotational;
  fem::ImplicitEuler sim(*b.h, *solver, b.f_ext, sp);
  sim.set_state(u0, v0);
  if (!s.corotational)
    notes.push_back("rotations: skipped (linear material); matrices assembled and factorised once");
  if (!solver->uses_levels() && b.h->num_levels() > 1)
    notes.push_back("lower degrees: not assembled (" + solver->name() + " needs only the finest level)");
  if (!s.energy) notes.push_back("energies: not recorded (output.energy false)");

  const std::string out = cli.output;
  const bool frames = !out.empty() && s.frame_every > 0;
  if (!out.empty()) make_dir(out);
  else notes.push_back("output: nothing written (no output.directory)");

  const int steps = static_cast<int>(std::llround(s.duration / s.dt));
  std::ostringstream csv;
  csv.precision(10);
  csv << "step,time,probe_ux,probe_uy,probe_uz,kinetic,elastic,total_energy,iterations,rel_residual,residual_b";
  for (int k = 0; k < fem::kNumStages; ++k) csv << "," << fem::stage_name(k) << "_s";
  csv << "\n";
  std::vector<std::pair<double, std::string>> pvd;
  double out_seconds = 0.0;
  auto energies = [&](double& kin, double& el, double& tot) {
    kin = sim.kinetic_energy();
    el = sim.elastic_energy();
    tot = kin + el - sim.external_work();
  };
  auto write_outputs = [&](bool frame) {
    const auto t0 = Clock::now();
    if (frame && frames) {
      const std::string name = frame_name(sim.steps());
      fem::write_vtu(out + "/" + name, m.space(), sim.displacement());  // complete once renamed
      pvd.emplace_back(sim.time(), name);
      fem::write_pvd(out + "/simulation.pvd", pvd);
    }
    if (!out.empty()) write_file_atomically(out + "/steps.csv", csv.str());
    out_seconds += since(t0);
  };

  double kin = 0, el = 0, E0 = 0, Emax_growth = 0, Epeak = 0;
  energies(kin, el, E0);
  double E_prev = E0;
  Epeak = E0;
  const fem::Vec3 d0 = probe_displacement(b, sim.displacement());
  csv << 0 << "," << 0.0 << "," << d0.x() << "," << d0.y() << "," << d0.z() << "," << kin << "," << el << "," << E0 << ",0,0,0";
  for (int k = 0; k < fem::kNumStages; ++k) csv << ",0";
  csv << "\n";
  write_outputs(true);

  std::cout << "time:    " << steps << " steps of " << s.dt << " s (" << s.duration << " s), implicit Euler"
            << (s.rayleigh_alpha > 0 || s.rayleigh_beta > 0 ? ", Rayleigh damping" : ", undamped") << "\n"
            << "solver:  " << settings << " per step, warm start\n\n";

  std::array<double, fem::kNumStages> total{};
  long iterations = 0;
  int max_iterations = 0;
  double max_residual = 0.0, zmin = d0.z(), zmax = d0.z();
  Progress progress(steps, cli.quiet);
  const auto t_run = Clock::now();
  int failed_step = 0;
  std::string failure;
  for (int n = 1; n <= steps; ++n) {
    fem::StepStats st;
    try {
      st = sim.step();
    } catch (const Error& e) {
      failed_step = n;
      failure = e.what();
      break;
    }
    for (int k = 0; k < fem::kNumStages; ++k) total[k] += st.seconds[k];
    iterations += st.iterations;
    max_iterations = std::max(max_iterations, st.iterations);
    max_residual = std::max(max_residual, st.residual);
    const fem::Vec3 d = probe_displacement(b, sim.displacement());
    zmin = std::min(zmin, d.z()), zmax = std::max(zmax, d.z());
    double tot = std::nan("");
    kin = el = std::nan("");
    if (s.energy) {
      energies(kin, el, tot);
      Emax_growth = std::max(Emax_growth, tot - E_prev);
      Epeak = std::max(Epeak, tot);
      E_prev = tot;
    }
    csv << n << "," << st.time << "," << d.x() << "," << d.y() << "," << d.z() << "," << kin << "," << el << ","
        << tot << "," << st.iterations << "," << st.rel_residual << "," << st.residual;
    for (int k = 0; k < fem::kNumStages; ++k) csv << "," << st.seconds[k];
    csv << "\n";
    const bool frame = frames && (n % s.frame_every == 0 || n == steps);
    if (frame) write_outputs(true);
    progress.update(n, st.time);
  }
  const double wall = since(t_run);
  if (failed_step) progress.interrupt();
  if (!out.empty()) write_outputs(false);

  const int done = sim.steps();
  Table t({"stage", "total [s]", "per step [ms]", "share"});
  double sum = out_seconds;
  for (double x : total) sum += x;
  for (int k = 0; k < fem::kNumStages; ++k)
    if (total[k] > 0)
      t.add({fem::stage_name(k), fmt("%.3f", total[k]), fmt("%.3f", 1e3 * total[k] / std::max(done, 1)), fmt("%.1f%%", 100 * total[k] / sum)});
  if (!out.empty()) t.add({"output", fmt("%.3f", out_seconds), fmt("%.3f", 1e3 * out_seconds / std::max(done, 1)), fmt("%.1f%%", 100 * out_seconds / sum)});
  std::cout << "\n";
  t.print(std::cout);
  const fem::Vec3 d = probe_displacement(b, sim.displacement());
  std::cout << "\nsteps:   " << done << " in " << fmt("%.2f", wall) << " s wall, " << fmt("%.2f", done > 0 ? static_cast<double>(iterations) / done : 0.0)
            << " " << (method == "pmg" ? "cycles" : "iterations") << " per step (max " << max_iterations
            << "), largest ||b - Av|| / ||b|| " << fmt("%.1e", max_residual) << "\n"
            << "probe:   (" << b.probe.transpose() << "): displacement now " << d.transpose() << ", z range ["
            << fmt("%.4f", zmin) << ", " << fmt("%.4f", zmax) << "] m\n";
  if (s.energy)
    std::cout << "energy:  " << fmt("%.6g", E0) << " J at t = 0, " << fmt("%.6g", E_prev) << " J at t = " << fmt("%.3f", sim.time())
              << " s (" << fmt("%+.2f%%", E0 != 0 ? 100 * (E_prev - E0) / std::abs(E0) : 0.0) << "); peak "
              << fmt("%.3e", E0 != 0 ? (Epeak - E0) / std::abs(E0) : 0.0) << " above the start, largest one-step rise "
              << fmt("%.2e", Emax_growth) << " J\n";
  for (const auto& note : notes) std::cout << "note:    " << note << "\n";
  report["time"] = {{"dt_s", s.dt}, {"duration_s", s.duration}, {"steps_planned", steps}};
  report["solver"] = {{"method", method}, {"settings", settings}};
  json stages = json::array();
  for (int k = 0; k < fem::kNumStages; ++k)
    stages.push_back({{"stage", fem::stage_name(k)}, {"total_s", total[k]}, {"per_step_ms", 1e3 * total[k] / std::max(done, 1)}});
  if (!out.empty()) stages.push_back({{"stage", "output"}, {"total_s", out_seconds}, {"per_step_ms", 1e3 * out_seconds / std::max(done, 1)}});
  report["stages"] = stages;
  report["steps"] = {{"done", done},
                     {"wall_s", wall},
                     {"iterations_per_step", done > 0 ? static_cast<double>(iterations) / done : 0.0},
                     {"max_iterations", max_iterations},
                     {"iterations_are", method == "pmg" ? "cycles" : "iterations"},
                     {"largest_residual_b", max_residual}};
  report["probe"] = {{"point_m", vec3(b.probe)}, {"displacement_m", vec3(d)}, {"z_range_m", {zmin, zmax}}};
  if (s.energy)
    report["energy"] = {{"initial_J", E0}, {"final_J", E_prev}, {"peak_J", Epeak}, {"largest_step_rise_J", Emax_growth}};
  if (!out.empty()) {
    report["outputs"] = {out + "/steps.csv"};
    if (frames) report["outputs"].push_back(out + "/simulation.pvd");
  }
  if (failed_step) report["failure"] = {{"step", failed_step}, {"message", failure}};
  if (!out.empty())
    std::cout << "output:  " << out << "/steps.csv" << (frames ? ", " + out + "/simulation.pvd (" + std::to_string(pvd.size()) + " frames)" : "") << "\n";
  if (failed_step) {
    std::cout << "\nsimulation failed at step " << failed_step << ": " << failure << "\n";
    throw Exit{kSolveFailed};
  }
}

void run(const Cli& cli_in) {
  Cli cli = cli_in;
  if (cli.threads > 0) omp_set_num_threads(cli.threads);
  SimScene s = cli.scene.empty() ? SimScene{} : read_scene(cli.scene);
  if (cli.scene.empty()) s.initial = "deflected";  // the default scene: a released cantilever
  if (cli.duration > 0) s.duration = cli.duration;
  if (cli.dt > 0) s.dt = cli.dt;
  if (cli.output.empty()) cli.output = s.output;
  if (cli.print_scene) {
    std::cout << scene_to_json(s);
    return;
  }
  const auto t0 = Clock::now();
  Built b = build(s);
  const fem::ElasticityModel& m = b.h->finest();
  std::cout << "scene:   " << s.source << "\n"
            << "mesh:    " << (s.mesh_file.empty() ? "box bar " + std::to_string(s.box[0]) + "x" + std::to_string(s.box[1]) + "x" + std::to_string(s.box[2]) + " boxes" : s.mesh_file)
            << (s.refine > 0 ? " refined " + std::to_string(s.refine) + "x" : "")
            << ", " << b.mesh.num_tets() << " tets, degree " << s.degree << ", " << m.num_free_dofs() << " unknowns, "
            << m.num_fixed() << " clamped nodes\n"
            << "model:   " << (s.corotational ? "corotational" : "linear") << ", E = " << s.young << " Pa, nu = " << s.poisson
            << ", rho = " << s.density << " kg/m^3; initial state " << s.initial << "\n"
            << "set-up:  " << fmt("%.3f", since(t0)) << " s, " << omp_get_max_threads() << " threads\n";
  json report = {{"command", "pmg simulate"},
                 {"scene", s.source},
                 {"mesh", {{"source", s.mesh_file.empty() ? "box" : s.mesh_file},
                           {"tets", b.mesh.num_tets()},
                           {"degree", s.degree},
                           {"unknowns", m.num_free_dofs()},
                           {"clamped_nodes", m.num_fixed()}}},
                 {"model", {{"material", s.corotational ? "corotational" : "linear"},
                            {"young_Pa", s.young},
                            {"poisson", s.poisson},
                            {"density_kg_m3", s.density},
                            {"initial_state", s.initial}}},
                 {"setup_s", since(t0)},
                 {"threads", omp_get_max_threads()}};
  auto write_report = [&] {
    if (!cli.json_report.empty()) write_file_atomically(cli.json_report, report.dump(2) + "\n");
  };
  try {
    if (s.dynamic) run_dynamic(s, b, cli, report);
    else run_static(s, b, cli, report);
  } catch (const Exit&) {  // a failed step: the report says where and why
    write_report();
    throw;
  }
  write_report();
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto cli = std::make_shared<Cli>();
  auto* sub = app.add_subcommand("simulate", "run a simulation scene (JSON); no file: the built-in cantilever");
  sub->add_option("scene", cli->scene, "scene file (JSON)")->check(CLI::ExistingFile);
  sub->add_option("-o,--output", cli->output, "write steps.csv and .vtu frames here (overrides output.directory)");
  sub->add_option("--duration", cli->duration, "override time.duration [s]")->check(CLI::PositiveNumber);
  sub->add_option("--dt", cli->dt, "override time.dt [s]")->check(CLI::PositiveNumber);
  sub->add_option("--threads", cli->threads, "OpenMP threads");
  sub->add_flag("--print-scene", cli->print_scene, "print the scene as JSON (a template to edit) and stop");
  sub->add_flag("-q,--quiet", cli->quiet, "no progress lines");
  sub->add_option("--json", cli->json_report,
                  "also write every figure of the report to this JSON file (units in the key names)");
  sub->callback([cli] { run(*cli); });
}

}  // namespace pmg::tools
