// pmg/sim/run.hpp — running a scene: the time loop of implicit Euler with the scene's outputs
// (steps.csv, .vtu frames, simulation.pvd, each written to a temporary name and renamed), the
// energies and the probe per step, and a summary of every figure `pmg simulate` reports; or the
// static solve of a static scene.
//
//   pmg::sim::SceneSetup setup = pmg::sim::set_up(scene);
//   pmg::sim::DynamicRun run(scene, setup, "out");
//   pmg::sim::RunSummary summary = run.run();   // a failed step ends the run: summary.failed_step
#pragma once

#include "pmg/fem/simulation.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/sim/setup.hpp"

#include <array>
#include <csignal>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace pmg::sim {

/// One row of steps.csv: the state after a step (step 0: the initial state).
struct StepRecord {
  int step = 0;
  double time = 0.0;
  fem::Vec3 probe = fem::Vec3::Zero();  ///< probe displacement
  double kinetic = 0.0, elastic = 0.0, total_energy = 0.0;  ///< NaN when not recorded
  int iterations = 0;
  double rel_residual = 0.0, residual = 0.0;
  std::array<double, fem::kNumStages> stage_s{};
};

struct RunSummary {
  int steps_planned = 0, steps_done = 0;
  double wall_s = 0.0;                          ///< the time loop, outputs included
  std::array<double, fem::kNumStages> stage_s{};  ///< per stage, summed over the steps
  double output_s = 0.0;
  long iterations = 0;  ///< summed over the steps (cycles for PMG)
  int max_iterations = 0;
  double max_residual = 0.0;  ///< largest ‖b − Av‖/‖b‖ of a step
  fem::Vec3 probe = fem::Vec3::Zero();  ///< final probe displacement
  double probe_z_min = 0.0, probe_z_max = 0.0;
  bool energy = false;  ///< energies recorded (output.energy)
  double energy_initial = 0.0, energy_final = 0.0, energy_peak = 0.0, energy_max_rise = 0.0;
  int frames = 0;
  std::vector<std::string> outputs;  ///< files written
  int failed_step = 0;               ///< 0: every step succeeded
  std::string failure;
  bool interrupted = false;          ///< stopped early by the stop flag (set_stop_flag)
  std::vector<StepRecord> records;   ///< step 0 and every step done, as in steps.csv
};

class DynamicRun {
 public:
  /// Builds the step solver and the initial state (nothing is stepped yet). output_dir empty:
  /// nothing is written. setup.notes gains what the run does once or skips.
  DynamicRun(const Scene& scene, SceneSetup& setup, const std::string& output_dir);
  const std::string& solver_settings() const { return settings_; }
  /// The solver's method ("pmg", "cg", …; "cholmod" for degree 1 with a multigrid method).
  const std::string& method() const { return method_; }
  /// A flag (set by a signal handler, say) that run() reads after every step: when it is non-zero
  /// the run stops after the step in progress, writes its outputs complete and reports
  /// RunSummary::interrupted.
  void set_stop_flag(const volatile std::sig_atomic_t* flag) { stop_ = flag; }
  int steps() const { return steps_; }
  /// Runs every step; progress(step, time) after each. A failed step (a solve that fails, a
  /// non-finite state) ends the run: the summary names it, the outputs so far stay written.
  RunSummary run(const std::function<void(int, double)>& progress = {});

 private:
  const Scene& scene_;
  SceneSetup& setup_;
  std::string output_, method_, settings_;
  std::unique_ptr<Solver> solver_;
  std::unique_ptr<fem::ImplicitEuler> sim_;
  int steps_ = 0;
  const volatile std::sig_atomic_t* stop_ = nullptr;
};

struct StaticOutcome {
  fem::StaticResult result;
  double seconds = 0.0;
  fem::Vec3 probe = fem::Vec3::Zero();
  std::vector<std::string> outputs;
};

/// A static scene: one CHOLMOD solve (a fixed point on the rotations when corotational), written
/// to output_dir/static.vtu when output_dir is not empty.
StaticOutcome solve_static(const Scene& scene, SceneSetup& setup, const std::string& output_dir);

}  // namespace pmg::sim
