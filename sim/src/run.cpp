#include "pmg/sim/run.hpp"
#include "pmg/sparse/threads.hpp"
#include "text.hpp"

#include "pmg/fem/mixed.hpp"
#include "pmg/fem/mixed_euler.hpp"
#include "pmg/fem/vtk_writer.hpp"
#include "pmg/solvers.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/timer.hpp"
#ifdef PMG_HAVE_DISTRIBUTED
#include "pmg/distributed/dynamics.hpp"
#include "pmg/distributed/mesh_problem.hpp"
#endif

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace pmg::sim {

using detail::fixed;

namespace {

void make_dir(const std::string& dir) {
  if (mkdir(dir.c_str(), 0777) != 0 && errno != EEXIST)
    throw InputError("output.directory: cannot create '" + dir + "'");
}

/// The clamp and the loads of a scene's outputs (static.vtu, the frames), for pictures (pmg render).
fem::VtuOptions clamp_and_loads(const SceneSetup& setup) {
  const fem::ElasticityModel& m = setup.finest();
  fem::VtuOptions vo;
  vo.fixed.resize(static_cast<size_t>(m.num_nodes()));
  for (index_t i = 0; i < m.num_nodes(); ++i) vo.fixed[i] = m.is_fixed(i) ? 1 : 0;
  vo.load = setup.f_ext;
  return vo;
}

std::string frame_stem(int step) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "frame_%06d", step);
  return buf;
}

}  // namespace

namespace detail {

/// What the time loop needs of a stepper: fem::ImplicitEuler in this process, or
/// dist::DistributedEuler across the ranks of the job.
class Stepper {
 public:
  virtual ~Stepper() = default;
  virtual fem::StepStats step() = 0;
  virtual double time() const = 0;
  virtual int steps() const = 0;
  virtual double kinetic_energy() const = 0;
  virtual double elastic_energy() const = 0;
  virtual double external_work() const = 0;
  /// The probe's displacement in the current state.
  virtual fem::Vec3 probe() const = 0;
  /// Writes the current state as `directory/stem` + an extension; returns the file the .pvd names.
  virtual std::string write_frame(const std::string& directory, const std::string& stem) const = 0;
  /// This process writes the run's own files (steps.csv, simulation.pvd).
  virtual bool writes_run_files() const { return true; }
  /// Whether the run stops, from this process's stop flag (every rank must decide alike).
  virtual bool stop(bool requested_here) const { return requested_here; }
  /// Runs f, this process's own work (writing a file): across ranks, a failure on any rank is
  /// thrown on every rank, so that none goes on stepping alone.
  virtual void together(const std::function<void()>& f) const { f(); }
  /// Refuses an output directory the ranks do not share (a no-op in one process).
  virtual void check_output(const std::string& directory) const { (void)directory; }
};

namespace {

/// The members both steppers forward to their time stepper T.
template <class T>
class SteppingWith : public Stepper {
 public:
  fem::StepStats step() override { return sim_->step(); }
  double time() const override { return sim_->time(); }
  int steps() const override { return sim_->steps(); }
  double kinetic_energy() const override { return sim_->kinetic_energy(); }
  double elastic_energy() const override { return sim_->elastic_energy(); }
  double external_work() const override { return sim_->external_work(); }
 protected:
  std::unique_ptr<T> sim_;
};

class SerialStepper final : public SteppingWith<fem::ImplicitEuler> {
 public:
  SerialStepper(const Scene& scene, SceneSetup& setup, const fem::SimulationParams& sp, const Vector& u0,
                const Vector& v0, std::string& method, std::string& settings)
      : setup_(setup) {
    solver_ = make_step_solver(scene, *setup.hierarchy, method, settings, setup.notes);
    sim_ = std::make_unique<fem::ImplicitEuler>(*setup.hierarchy, *solver_, setup.f_ext, sp);
    sim_->set_state(u0, v0);
    for (std::string& note : sim_->bound_system().notes()) setup.notes.push_back(std::move(note));
  }
  fem::Vec3 probe() const override { return setup_.probe.displacement(setup_.finest(), sim_->displacement()); }
  std::string write_frame(const std::string& directory, const std::string& stem) const override {
    if (frame_options_.fixed.empty()) frame_options_ = clamp_and_loads(setup_);
    fem::write_vtu(directory + "/" + stem + ".vtu", setup_.finest().space(), sim_->displacement(), frame_options_);
    return stem + ".vtu";
  }

 private:
  mutable fem::VtuOptions frame_options_;  // the clamp and loads of every frame, made with the first
  SceneSetup& setup_;
  std::unique_ptr<Solver> solver_;
};

/// A dynamic scene of the mixed formulation in this process (pmg/fem/mixed_euler.hpp): the
/// saddle point of each step on the scene's displacement hierarchy (set up on the shear material),
/// its solver set up once; a deflected start is the mixed static solve under the initial force;
/// every frame carries the pressure.
class MixedStepper final : public SteppingWith<fem::MixedEuler> {
 public:
  MixedStepper(const Scene& scene, SceneSetup& setup, const fem::SimulationParams& sp, std::string& method,
               std::string& settings)
      : setup_(setup), mixed_(fem::Material{scene.young, scene.poisson, scene.density}, *setup.hierarchy) {
    const fem::ElasticityModel& m = setup.finest();
    auto [u0, v0] = formula_state(scene, m, setup.lo, setup.hi);  // rest and deflected: zero
    Vector p0;
    Config c = scene.solver.clone();
    method = c.get_string("method", "mixed-gmres");
    start_libraries(c);
    if (scene.initial == "deflected") {
      const auto t0 = Clock::now();
      const int axis = scene.clamp_axis;
      const Vector f = end_force(m, axis, setup.hi[axis], 1e-9 * (setup.hi[axis] - setup.lo[axis]), scene.initial_force);
      Config statics = c.clone();
      if (method_accepts_key(method, "tol")) statics.set("tol", "1e-10");
      fem::StaticOptions so;
      so.corotational_tol = 1e-6;  // as the displacement-only deflected start
      const fem::MixedResult r = fem::solve_mixed_static(mixed_, f, statics, nullptr, scene.corotational, so);
      u0 = r.u;
      p0 = r.p;
      setup.notes.push_back("initial state: the mixed static deflection under the end force, " +
                            std::to_string(r.fixed_point_iterations) + " fixed-point iterations, " +
                            std::to_string(r.solver_iterations) + " solver iterations, " + fixed(seconds_since(t0), 2) +
                            " s");
    }
    // Made whole before it is kept: were set_state() to throw, the stepper dies before mixed_.
    auto euler = std::make_unique<fem::MixedEuler>(mixed_, c, setup.f_ext, sp);
    euler->set_state(u0, v0, p0);
    sim_ = std::move(euler);
    settings = c.to_string();
    setup.notes.push_back("mixed formulation: " + std::to_string(mixed_.num_displacement()) + " displacement + " +
                          std::to_string(mixed_.num_pressure()) + " pressure unknowns; the solver set up in " +
                          fixed(sim_->setup_seconds(), 2) + " s" +
                          (scene.corotational ? ", updated to each step's rotations (coupling B_R included)"
                                              : " once for every step") + ", each step warm-started");
  }
  /// The stepper (in the base) refers to mixed_, a member of this class: it goes first.
  ~MixedStepper() override { sim_.reset(); }
  fem::Vec3 probe() const override { return setup_.probe.displacement(setup_.finest(), sim_->displacement()); }
  std::string write_frame(const std::string& directory, const std::string& stem) const override {
    frame_options_.pressure = mixed_.pressure_on_displacement_nodes(sim_->pressure());
    fem::write_vtu(directory + "/" + stem + ".vtu", setup_.finest().space(), sim_->displacement(), frame_options_);
    return stem + ".vtu";
  }

 private:
  SceneSetup& setup_;
  fem::MixedElasticity mixed_;
  mutable fem::VtuOptions frame_options_ = clamp_and_loads(setup_);  // the clamp, loads and pressure
};

#ifdef PMG_HAVE_DISTRIBUTED
/// petsc-mgpcg's keys from the scene's solver options (a rounding floor for warm starts; a key it
/// does not read is an error, as make_solver() says), the start-up of MPI and PETSc as a note.
dist::DistributedMgpcgParams step_params(const Config& solver, SceneSetup& setup, std::string& settings) {
  Config c = solver.clone();
  c.set_default("rhs_floor", "1e-12");  // warm-started steps end at once within rounding
  const double start = start_libraries(c);
  if (start >= 0) {
    char text[64];
    std::snprintf(text, sizeof text, "MPI (and PETSc) start-up: %.3f s", start);
    setup.notes.push_back(text);
  }
  c.mark_used("method");
  dist::DistributedMgpcgParams params = read_params<dist::DistributedMgpcgParams>(c);
  params.allow_unused_options = unused_options_allowed(c);
  check_keys_used(c);
  settings = c.to_string();
  return params;
}

/// The scene's probe point located on the ranks (every rank alike); InputError naming the key when
/// no rank's elements hold it.
dist::DistributedEuler::Located locate_probe(const dist::DistributedEuler& e, const fem::Vec3& point) {
  try {
    return e.locate(point);
  } catch (const InputError& x) {
    throw InputError(std::string("output.probe: ") + x.what());
  }
}

/// The scene's solver options as petsc-mgpcg's, the route's one method: a scene naming it keeps
/// them all; another method's stopping rule (tol, max_iterations, rhs_floor, throw_on_failure) is
/// kept and its other keys, whose values mean that method's choices, are named in a note.
Config petsc_mgpcg_keys(const Scene& scene, std::vector<std::string>& notes) {
  const std::string named = scene.solver.get_string("method", "petsc-mgpcg");
  if (named == "petsc-mgpcg") return scene.solver.clone();
  Config c = Config::from_pairs({"method=petsc-mgpcg"}, scene.solver.origin());
  std::string dropped;
  for (const auto& [key, value] : scene.solver.items()) {
    if (key == "method") continue;
    if (key == "tol" || key == "max_iterations" || key == "rhs_floor" || key == "throw_on_failure") c.set(key, value);
    else dropped += (dropped.empty() ? "" : ", ") + key;
  }
  notes.push_back("solver: petsc-mgpcg across the ranks in place of the scene's " + named +
                  (dropped.empty() ? std::string() : " (its keys " + dropped + " not taken)"));
  return c;
}

/// dist::DistributedEuler across the ranks of the job: each rank writes its piece of a frame, rank
/// 0 the run's files; stop requests, output failures and the output directory agreed on.
class AcrossRanks : public SteppingWith<dist::DistributedEuler> {
 public:
  std::string write_frame(const std::string& directory, const std::string& stem) const override {
    return sim_->write_frame(directory, stem);
  }
  bool writes_run_files() const override { return sim_->ranks().rank() == 0; }
  bool stop(bool requested_here) const override { return sim_->any_rank(requested_here); }
  void together(const std::function<void()>& f) const override {
    std::string error;
    try {
      f();
    } catch (const std::exception& e) {
      error = e.what();
    }
    sim_->agree(error, "output");
  }
  void check_output(const std::string& directory) const override {
    // Every rank writes its frame pieces into the one directory rank 0 lists them in.
    sim_->require_same_on_every_rank("the output directory", directory);
  }

 protected:
  static std::string rank_note(const Scene& scene, int ranks) {
    return "ranks: " + std::to_string(ranks) + "; each steps its own elements (" +
           (scene.corotational ? "rotations, forces, energies; degrees >= 2 matrix-free, the linear level assembled "
                                 "per step"
                               : "forces, energies; degrees >= 2 matrix-free, the linear level assembled once") +
           ") and writes its own piece of each frame (.pvtu)";
  }
};

/// The replicated set-up: every rank holds the serial scene and takes its share.
class RankStepper final : public AcrossRanks {
 public:
  RankStepper(const Scene& scene, SceneSetup& setup, const fem::SimulationParams& sp, const Vector& u0,
              const Vector& v0, std::string& settings) {
    sim_ = std::make_unique<dist::DistributedEuler>(*setup.hierarchy, setup.f_ext, sp, step_params(scene.solver, setup, settings));
    sim_->set_state(u0, v0);
    // A vertex probe becomes a corner of an element holding it: the value there is the vertex's.
    const Probe& p = setup.probe;
    element_ = p.element, barycentric_ = p.barycentric;
    if (p.vertex >= 0) {
      const fem::TetMesh& mesh = *setup.mesh;
      for (index_t e = 0; e < mesh.num_tets() && element_ < 0; ++e)
        for (int k = 0; k < 4; ++k)
          if (mesh.tets[e][k] == p.vertex) element_ = e, barycentric_ = Eigen::Vector4d::Unit(k);
    }
    setup.notes.push_back(rank_note(scene, sim_->ranks().size()));
  }
  fem::Vec3 probe() const override { return sim_->displacement_at(element_, barycentric_); }

 private:
  index_t element_ = -1;
  Eigen::Vector4d barycentric_ = Eigen::Vector4d::Zero();
};

/// A mesh no rank holds whole (set_up_on_ranks): the initial state from each rank's own part — a
/// formula on its nodes, or the static deflection solved across the ranks — and a probe point
/// located once.
class RankMeshStepper final : public AcrossRanks {
 public:
  RankMeshStepper(const Scene& scene, SceneSetup& setup, const fem::SimulationParams& sp, std::string& settings) {
    dist::MeshProblem& problem = *setup.on_ranks;
    sim_ = std::make_unique<dist::DistributedEuler>(problem.ranks(), problem.load(), sp,
                                                    step_params(petsc_mgpcg_keys(scene, setup.notes), setup, settings));
    if (scene.initial == "deflected") {
      const auto t0 = Clock::now();
      fem::StaticOptions so;
      so.corotational_tol = 1e-6;  // as the serial scene's deflected start
      const int iterations = sim_->set_static_state(problem.end_traction(scene.initial_force), so);
      char text[160];
      std::snprintf(text, sizeof text,
                    "initial state: static deflection under the end force solved across the ranks, %d fixed-point "
                    "iterations, %.2f s",
                    iterations, seconds_since(t0));
      setup.notes.push_back(text);
    } else {
      const auto [u, v] = formula_state(scene, problem.ranks().local().finest(), setup.lo, setup.hi);
      sim_->set_state_local(u, v);
    }
    probe_ = locate_probe(*sim_, setup.probe.point);
    setup.notes.push_back(rank_note(scene, sim_->ranks().size()) +
                          "; the mesh, its numbering, loads and initial state built on the ranks, none holding it whole");
  }
  fem::Vec3 probe() const override { return sim_->displacement_at(probe_); }

 private:
  dist::DistributedEuler::Located probe_;
};
#endif

}  // namespace
}  // namespace detail

bool written_by_run(const std::string& name) {
  if (name == "steps.csv" || name == "simulation.pvd" || name == "static.vtu" || name == "static.pvtu") return true;
  if (name.rfind("static_", 0) == 0) return name.size() > 4 && name.compare(name.size() - 4, 4, ".vtu") == 0;
  if (name.rfind("frame_", 0) != 0) return false;
  const size_t dot = name.rfind('.');
  const std::string ext = dot == std::string::npos ? "" : name.substr(dot);
  return ext == ".vtu" || ext == ".pvtu";
}

void plan_files(const Scene& scene, const std::string& scene_file, const std::string& output_dir, FilePlan& plan) {
  plan.input(scene_file, "the scene file");
  plan.input(scene.mesh_file, "the scene's mesh file");
  plan.output_folder(output_dir, "the output folder", written_by_run);
}

bool runs_across_ranks(const Scene& scene) {
#ifdef PMG_HAVE_DISTRIBUTED
  // What the method's registration says (SolverInfo::across_ranks), not its name.
  if (!scene.dynamic || scene.degree < 2) return false;
  register_all_solvers();  // the registrations say which methods run across ranks
  const std::string method = scene.solver.get_string("method", kDefaultDynamicMethod);
  try {
    return solver_info(method).across_ranks;
  } catch (const InputError&) {
    return false;  // an unknown method: the serial stepper's factory call names it
  }
#else
  (void)scene;
  return false;
#endif
}

DynamicRun::DynamicRun(const Scene& scene, SceneSetup& setup, const std::string& output_dir)
    : scene_(scene), setup_(setup), output_(output_dir) {
  if (!scene.dynamic) throw InputError("DynamicRun: the scene is static (time: \"static\")");
  fem::SimulationParams sp;
  sp.dt = scene.dt;
  sp.rayleigh_alpha = scene.rayleigh_alpha;
  sp.rayleigh_beta = scene.rayleigh_beta;
  sp.corotational = scene.corotational;
  if (scene.formulation == "mixed") {
    if (setup.on_ranks) throw InputError("formulation mixed: not across MPI ranks yet");
    stepper_ = std::make_unique<detail::MixedStepper>(scene, setup, sp, method_, settings_);
  }
#ifdef PMG_HAVE_DISTRIBUTED
  else if (setup.on_ranks) {
    method_ = "petsc-mgpcg";
    stepper_ = std::make_unique<detail::RankMeshStepper>(scene, setup, sp, settings_);
  } else if (runs_across_ranks(scene)) {
    const auto [u0, v0] = initial_state(scene, setup);
    method_ = scene.solver.get_string("method", kDefaultDynamicMethod);
    stepper_ = std::make_unique<detail::RankStepper>(scene, setup, sp, u0, v0, settings_);
  }
#endif
  if (!stepper_) {
    if (setup.on_ranks) throw InputError("DynamicRun: a set-up across ranks needs a build with pmg::distributed");
    const auto [u0, v0] = initial_state(scene, setup);
    stepper_ = std::make_unique<detail::SerialStepper>(scene, setup, sp, u0, v0, method_, settings_);
  }
  steps_ = static_cast<int>(std::llround(scene.duration / scene.dt));
  auto& notes = setup.notes;
  if (!scene.corotational)
    notes.push_back("rotations: skipped (linear material); matrices assembled and factorised once");
  if (!scene.energy) notes.push_back("energies: not recorded (output.energy false)");
  if (output_.empty()) notes.push_back("output: nothing written (no output.directory)");
}

DynamicRun::~DynamicRun() = default;

namespace {

/// A one-step rise of the total energy above kEnergyRiseTolerance of the energies' scale: a warning
/// naming the step, the rise and the likely cause.
void warn_of_energy_rise(const Scene& scene, double energy_scale, RunSummary& r) {
  if (!(r.energy_max_rise > kEnergyRiseTolerance * energy_scale)) return;
  char text[640];
  std::snprintf(text, sizeof text,
                "the total energy rose by %.3g J in step %d (%.2g%% of the energies' scale %.4g J); implicit "
                "Euler%s dissipates energy: the time step does not resolve the motion for this material%s, or "
                "the steps' solves are too inexact (solver tol)",
                r.energy_max_rise, r.energy_rise_step, 100 * r.energy_max_rise / energy_scale, energy_scale,
                scene.rayleigh_alpha > 0 || scene.rayleigh_beta > 0 ? " with damping" : "",
                scene.poisson > 0.49 ? " (nearly incompressible: the displacement-only elements lock and each "
                                       "step's corotational linearisation is least accurate there)"
                                     : "");
  r.warnings.emplace_back(text);
}

}  // namespace

RunSummary DynamicRun::run(const std::function<void(int, double)>& progress) {
  detail::Stepper& sim = *stepper_;
  const bool frames = !output_.empty() && scene_.frame_every > 0;
  const bool run_files = !output_.empty() && sim.writes_run_files();
  sim.check_output(output_);
  if (!output_.empty()) sim.together([&] { make_dir(output_); });
  RunSummary r;
  r.steps_planned = steps_;
  r.energy = scene_.energy;

  std::ostringstream csv;
  csv.precision(10);
  csv << "step,time,probe_ux,probe_uy,probe_uz,kinetic,elastic,total_energy,iterations,rel_residual,residual_b";
  for (int k = 0; k < fem::kNumStages; ++k) csv << "," << fem::stage_name(k) << "_s";
  csv << "\n";
  std::vector<std::pair<double, std::string>> pvd;
  auto write_outputs = [&](bool frame) {
    const auto t0 = Clock::now();
    sim.together([&] {
      if (frame && frames) {
        const std::string name = sim.write_frame(output_, frame_stem(sim.steps()));  // complete once renamed
        pvd.emplace_back(sim.time(), name);
        if (run_files) fem::write_pvd(output_ + "/simulation.pvd", pvd);
      }
      if (run_files) write_file_atomically(output_ + "/steps.csv", csv.str());
    });
    r.output_s += seconds_since(t0);
  };
  // The elastic energy comes from the pass over the elements the next step reuses: free.
  auto energies = [&](double& kin, double& el, double& tot) {
    kin = sim.kinetic_energy();
    el = sim.elastic_energy();
    tot = kin + el - sim.external_work();
  };

  double kin = 0, el = 0;
  energies(kin, el, r.energy_initial);
  double E_prev = r.energy_initial;
  double energy_scale = std::abs(r.energy_initial);
  r.energy_peak = r.energy_initial;
  const fem::Vec3 d0 = sim.probe();
  r.probe_z_min = r.probe_z_max = d0.z();
  // Each state is kept as a record and written as its steps.csv line, from the same fields.
  auto record = [&](const StepRecord& rec) {
    r.records.push_back(rec);
    csv << rec.step << "," << rec.time << "," << rec.probe.x() << "," << rec.probe.y() << "," << rec.probe.z()
        << "," << rec.kinetic << "," << rec.elastic << "," << rec.total_energy << "," << rec.iterations << ","
        << rec.rel_residual << "," << rec.residual;
    for (int k = 0; k < fem::kNumStages; ++k) csv << "," << rec.stage_s[k];
    csv << "\n";
  };
  record({0, 0.0, d0, kin, el, r.energy_initial, 0, 0.0, 0.0, {}});
  write_outputs(true);

  const auto t_run = Clock::now();
  bool rejected = false;              // a step whose state was not finite
  fem::Vec3 last_probe = sim.probe();  // the probe after the last accepted step
  for (int n = 1; n <= steps_; ++n) {
    const ThreadBudget budget;  // the step, its energies and its output on the cores free now
    fem::StepStats st;
    try {
      st = sim.step();
    } catch (const Error& e) {
      r.failed_step = n;
      r.failure = e.what();
      break;
    }
    for (int k = 0; k < fem::kNumStages; ++k) r.stage_s[k] += st.seconds[k];
    r.iterations += st.iterations;
    r.max_iterations = std::max(r.max_iterations, st.iterations);
    r.max_residual = std::max(r.max_residual, st.residual);
    const fem::Vec3 d = sim.probe();
    double tot = std::nan("");
    kin = el = std::nan("");
    if (scene_.energy) energies(kin, el, tot);
    // A solve that met its tolerance can still leave a state beyond double range (loads near 1e308
    // overflow the energies): a failed step, never NaN in the outputs with success.
    if (!d.allFinite() || (scene_.energy && !(std::isfinite(kin) && std::isfinite(el)))) {
      r.failed_step = n;
      r.failure = "the state is no longer finite (overflow: loads, material or initial state beyond double range?)";
      rejected = true;  // the summary reports the steps before it
      break;
    }
    r.probe_z_min = std::min(r.probe_z_min, d.z()), r.probe_z_max = std::max(r.probe_z_max, d.z());
    last_probe = d;
    if (scene_.energy) {
      if (tot - E_prev > r.energy_max_rise) r.energy_max_rise = tot - E_prev, r.energy_rise_step = n;
      energy_scale = std::max(energy_scale, std::abs(kin) + std::abs(el));
      r.energy_peak = std::max(r.energy_peak, tot);
      E_prev = tot;
    }
    record({n, st.time, d, kin, el, tot, st.iterations, st.rel_residual, st.residual, st.seconds});
    if (frames && (n % scene_.frame_every == 0 || n == steps_)) write_outputs(true);
    if (progress) progress(n, st.time);
    if (sim.stop(stop_ && *stop_) && n < steps_) {
      r.interrupted = true;
      if (frames && n % scene_.frame_every != 0) write_outputs(true);  // the last finished step
      break;
    }
  }
  r.wall_s = seconds_since(t_run);
  if (!output_.empty()) write_outputs(false);
  r.steps_done = rejected ? sim.steps() - 1 : sim.steps();
  r.energy_final = E_prev;
  if (scene_.energy) warn_of_energy_rise(scene_, energy_scale, r);
  r.probe = rejected ? last_probe : sim.probe();
  r.frames = static_cast<int>(pvd.size());
  if (run_files) {
    r.outputs.push_back(output_ + "/steps.csv");
    if (frames) r.outputs.push_back(output_ + "/simulation.pvd");
  }
  return r;
}

#ifdef PMG_HAVE_DISTRIBUTED
namespace {

/// A static scene on a mesh no rank holds whole: the fixed point of pmg/fem/static_solve.hpp
/// across the ranks (DistributedEuler::set_static_state), each solve by petsc-mgpcg to the scene's
/// tol (1e-10 unless given), the probe located once, static.pvtu with one piece per rank.
StaticOutcome solve_static_on_ranks(const Scene& scene, SceneSetup& setup, const std::string& output_dir) {
  StaticOutcome out;
  const Config keys = detail::petsc_mgpcg_keys(scene, setup.notes);
  const double tol = keys.get_double("tol", 1e-10, 0.0, 1.0);
  const dist::DistributedMgpcgParams params = detail::step_params(keys, setup, out.settings);
  out.method = "petsc-mgpcg";
  dist::MeshProblem& problem = *setup.on_ranks;
  fem::SimulationParams sp;  // the static state only: no step is taken
  sp.corotational = scene.corotational;
  dist::DistributedEuler e(problem.ranks(), problem.load(), sp, params);
  const auto t0 = Clock::now();
  fem::StaticOptions so;
  so.corotational_tol = 1e-6;
  out.result.iterations = e.set_static_state(problem.load(), so, tol, &out.result.solver_iterations);
  out.seconds = seconds_since(t0);
  out.probe = e.displacement_at(detail::locate_probe(e, setup.probe.point));
  if (!output_dir.empty()) {
    e.require_same_on_every_rank("the output directory", output_dir);
    std::string error;
    try {
      make_dir(output_dir);
    } catch (const std::exception& x) {
      error = x.what();
    }
    e.agree(error, "output");
    const std::string name = e.write_frame(output_dir, "static");
    if (e.ranks().rank() == 0) out.outputs.push_back(output_dir + "/" + name);
  }
  return out;
}

}  // namespace
#endif

/// A static scene of the mixed formulation (pmg/fem/mixed.hpp): the saddle point on the scene's
/// mesh, clamp and supports, solved by the scene's saddle-point method; static.vtu gains the
/// pressure (raised to the displacement's degree).
StaticOutcome solve_static_mixed(const Scene& scene, SceneSetup& setup, const std::string& output_dir) {
  if (setup.on_ranks) throw InputError("formulation mixed: not across MPI ranks yet");
  fem::MixedElasticity mixed(fem::Material{scene.young, scene.poisson, scene.density}, *setup.hierarchy);
  StaticOutcome out;
  Config c = scene.solver.clone();
  out.method = c.get_string("method", "mixed-gmres");
  out.settings = c.to_string();
  start_libraries(c);
  const auto t0 = Clock::now();
  fem::StaticOptions so;
  so.corotational_tol = 1e-6;  // as the displacement-only static scenes
  const fem::MixedResult r = fem::solve_mixed_static(mixed, setup.f_ext, c, nullptr, scene.corotational, so);
  out.seconds = seconds_since(t0);
  out.result.u = r.u;
  out.result.iterations = r.fixed_point_iterations;
  out.result.solver_iterations = static_cast<int>(r.solver_iterations);
  const fem::ElasticityModel& m = mixed.hierarchy().finest();
  out.probe = setup.probe.displacement(m, out.result.u);
  std::ostringstream note;
  note << "mixed formulation: " << mixed.num_displacement() << " displacement + " << mixed.num_pressure()
       << " pressure unknowns, " << r.solver_iterations << " iterations; pressure in [" << r.p.minCoeff() << ", "
       << r.p.maxCoeff() << "] Pa";
  out.summary = note.str();
  if (!output_dir.empty()) {
    make_dir(output_dir);
    fem::VtuOptions vo = clamp_and_loads(setup);
    vo.pressure = mixed.pressure_on_displacement_nodes(r.p);
    fem::write_vtu(output_dir + "/static.vtu", m.space(), out.result.u, vo);
    out.outputs.push_back(output_dir + "/static.vtu");
  }
  return out;
}

StaticOutcome solve_static(const Scene& scene, SceneSetup& setup, const std::string& output_dir) {
  if (scene.formulation == "mixed") return solve_static_mixed(scene, setup, output_dir);
#ifdef PMG_HAVE_DISTRIBUTED
  if (setup.on_ranks) return solve_static_on_ranks(scene, setup, output_dir);
#endif
  if (setup.on_ranks) throw InputError("solve_static: a set-up across ranks needs a build with pmg::distributed");
  const fem::ElasticityModel& m = setup.finest();
  StaticOutcome out;
  const auto solver = make_step_solver(scene, *setup.hierarchy, out.method, out.settings, setup.notes);
  const auto t0 = Clock::now();
  fem::StaticOptions so;
  so.corotational_tol = 1e-6;
  out.result = fem::solve_static(*setup.hierarchy, setup.f_ext, scene.corotational, *solver, so);
  out.seconds = seconds_since(t0);
  out.probe = setup.probe.displacement(m, out.result.u);
  if (!output_dir.empty()) {
    make_dir(output_dir);
    fem::write_vtu(output_dir + "/static.vtu", m.space(), out.result.u, clamp_and_loads(setup));
    out.outputs.push_back(output_dir + "/static.vtu");
  }
  return out;
}

}  // namespace pmg::sim
