#include "pmg/sim/run.hpp"

#include "pmg/fem/vtk_writer.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/timer.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace pmg::sim {

namespace {


void make_dir(const std::string& dir) {
  if (mkdir(dir.c_str(), 0777) != 0 && errno != EEXIST)
    throw InputError("output.directory: cannot create '" + dir + "'");
}

std::string frame_name(int step) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "frame_%06d.vtu", step);
  return buf;
}

}  // namespace

DynamicRun::DynamicRun(const Scene& scene, SceneSetup& setup, const std::string& output_dir)
    : scene_(scene), setup_(setup), output_(output_dir) {
  if (!scene.dynamic) throw InputError("DynamicRun: the scene is static (time: \"static\")");
  const auto [u0, v0] = initial_state(scene, setup);
  solver_ = make_step_solver(scene, *setup.hierarchy, method_, settings_, setup.notes);
  fem::SimulationParams sp;
  sp.dt = scene.dt;
  sp.rayleigh_alpha = scene.rayleigh_alpha;
  sp.rayleigh_beta = scene.rayleigh_beta;
  sp.corotational = scene.corotational;
  sim_ = std::make_unique<fem::ImplicitEuler>(*setup.hierarchy, *solver_, setup.f_ext, sp);
  sim_->set_state(u0, v0);
  steps_ = static_cast<int>(std::llround(scene.duration / scene.dt));
  auto& notes = setup.notes;
  if (!scene.corotational)
    notes.push_back("rotations: skipped (linear material); matrices assembled and factorised once");
  const SolverNeeds needs = solver_->needs();
  if (needs.matrix_free)
    notes.push_back("matrix-free: degrees >= 2 never assembled (their operators take each step's "
                    "rotations); the linear level assembled and its solver set up per step");
  if (!needs.lower_levels && setup.hierarchy->num_levels() > 1)
    notes.push_back("lower degrees: not assembled (" + solver_->name() + " needs only the finest level)");
  if (!scene.energy) notes.push_back("energies: not recorded (output.energy false)");
  if (output_.empty()) notes.push_back("output: nothing written (no output.directory)");
}

RunSummary DynamicRun::run(const std::function<void(int, double)>& progress) {
  fem::ImplicitEuler& sim = *sim_;
  const fem::ElasticityModel& m = setup_.finest();
  const bool frames = !output_.empty() && scene_.frame_every > 0;
  if (!output_.empty()) make_dir(output_);
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
    if (frame && frames) {
      const std::string name = frame_name(sim.steps());
      fem::write_vtu(output_ + "/" + name, m.space(), sim.displacement());  // complete once renamed
      pvd.emplace_back(sim.time(), name);
      fem::write_pvd(output_ + "/simulation.pvd", pvd);
    }
    if (!output_.empty()) write_file_atomically(output_ + "/steps.csv", csv.str());
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
  r.energy_peak = r.energy_initial;
  const fem::Vec3 d0 = setup_.probe.displacement(m, sim.displacement());
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
  for (int n = 1; n <= steps_; ++n) {
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
    const fem::Vec3 d = setup_.probe.displacement(m, sim.displacement());
    r.probe_z_min = std::min(r.probe_z_min, d.z()), r.probe_z_max = std::max(r.probe_z_max, d.z());
    double tot = std::nan("");
    kin = el = std::nan("");
    if (scene_.energy) {
      energies(kin, el, tot);
      r.energy_max_rise = std::max(r.energy_max_rise, tot - E_prev);
      r.energy_peak = std::max(r.energy_peak, tot);
      E_prev = tot;
    }
    record({n, st.time, d, kin, el, tot, st.iterations, st.rel_residual, st.residual, st.seconds});
    if (frames && (n % scene_.frame_every == 0 || n == steps_)) write_outputs(true);
    if (progress) progress(n, st.time);
    if (stop_ && *stop_ && n < steps_) {
      r.interrupted = true;
      if (frames && n % scene_.frame_every != 0) write_outputs(true);  // the last finished step
      break;
    }
  }
  r.wall_s = seconds_since(t_run);
  if (!output_.empty()) write_outputs(false);
  r.steps_done = sim.steps();
  r.energy_final = E_prev;
  r.probe = setup_.probe.displacement(m, sim.displacement());
  r.frames = static_cast<int>(pvd.size());
  if (!output_.empty()) {
    r.outputs.push_back(output_ + "/steps.csv");
    if (frames) r.outputs.push_back(output_ + "/simulation.pvd");
  }
  return r;
}

StaticOutcome solve_static(const Scene& scene, SceneSetup& setup, const std::string& output_dir) {
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
    fem::write_vtu(output_dir + "/static.vtu", m.space(), out.result.u);
    out.outputs.push_back(output_dir + "/static.vtu");
  }
  return out;
}

}  // namespace pmg::sim
