// pmg/sim/run.hpp — running a scene: the time loop of implicit Euler with the scene's outputs
// (steps.csv, .vtu frames, simulation.pvd, each written to a temporary name and renamed), the
// energies and the probe per step, and a summary of every figure `pmg simulate` reports; or the
// static solve of a static scene. With the method petsc-mgpcg under mpirun the steps run across
// the ranks (pmg/distributed/dynamics.hpp): each frame is a .pvtu with one .vtu piece per rank,
// and rank 0 writes steps.csv and simulation.pvd.
//
//   pmg::sim::SceneSetup setup = pmg::sim::set_up(scene);
//   pmg::sim::DynamicRun run(scene, setup, "out");
//   pmg::sim::RunSummary summary = run.run();   // a failed step ends the run: summary.failed_step
#pragma once

#include "pmg/fem/simulation.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/sim/setup.hpp"
#include "pmg/sparse/file_io.hpp"

#include <array>
#include <csignal>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace pmg::sim {

namespace detail {
class Stepper;
}

/// True when a dynamic scene's steps run across the MPI ranks of the job (method petsc-mgpcg, a
/// degree >= 2, a build with the distributed library): every rank steps its own elements and
/// writes its own piece of each frame, rank 0 the rest. Otherwise every rank that runs the scene
/// runs all of it, and only one should be given an output directory.
bool runs_across_ranks(const Scene& scene);

/// Adds a scene's files to a run's plan (pmg::FilePlan): the scene file `scene_file` (empty or not
/// a file: none) and the scene's mesh as inputs, `output_dir` (may be empty) as the folder of steps.csv, simulation.pvd, static.vtu and the
/// frames (frame_NNNNNN.vtu, .pvtu and its per-rank pieces).
void plan_files(const Scene& scene, const std::string& scene_file, const std::string& output_dir, FilePlan& plan);
/// Whether a file named `name` in a scene's output folder is one a run writes.
bool written_by_run(const std::string& name);

/// A one-step rise of the total energy above this fraction of the energies' scale (the largest
/// kinetic + elastic energy of any state, or |E0|) is a warning: implicit Euler dissipates, and
/// the steps' inexact solves (tol 1e-3) and the corotational linearisation of fast rotations stay
/// far below it (the spinning scene: 5e-5).
inline constexpr double kEnergyRiseTolerance = 1e-3;

/// One row of steps.csv: the state after a step (step 0: the initial state).
struct StepRecord {
  /// Step number (0: the initial state).
  int step = 0;
  /// Simulated time after the step, seconds.
  double time = 0.0;
  fem::Vec3 probe = fem::Vec3::Zero();  ///< probe displacement
  /// \var elastic
  /// Elastic (strain) energy of the state; NaN after step 0 when energies are not recorded.

  /// Kinetic energy of the state. It, `elastic` and `total_energy` are NaN after step 0 when
  /// energies are not recorded (output.energy false).
  double kinetic = 0.0, elastic = 0.0, total_energy = 0.0;  ///< kinetic + elastic - external work
  /// Iterations (cycles for a multigrid method) of the step's solve; 0 for step 0.
  int iterations = 0;
  /// True residual of the step's solve relative to its start (fem::StepStats::rel_residual).
  double rel_residual = 0.0, residual = 0.0;  ///< true ||b - A v|| / ||b|| of the step's solve
  /// Wall time of each stage of the step (fem::Stage), seconds; 0 for skipped stages and step 0.
  std::array<double, fem::kNumStages> stage_s{};
};

/// What DynamicRun::run() did: every figure `pmg simulate` reports, and the per-step records.
struct RunSummary {
  /// Steps the scene asks for: duration / dt, rounded.
  int steps_planned = 0, steps_done = 0;  ///< steps completed (fewer on failure or interruption)
  double wall_s = 0.0;                          ///< the time loop, outputs included
  std::array<double, fem::kNumStages> stage_s{};  ///< per stage, summed over the steps
  /// Seconds spent writing steps.csv and the frames, the initial state's included.
  double output_s = 0.0;
  long iterations = 0;  ///< summed over the steps (cycles for PMG)
  /// Most iterations (cycles) of any one step.
  int max_iterations = 0;
  double max_residual = 0.0;  ///< largest ‖b − Av‖/‖b‖ of a step
  fem::Vec3 probe = fem::Vec3::Zero();  ///< final probe displacement
  /// Smallest z displacement of the probe over every state, the initial one included.
  double probe_z_min = 0.0, probe_z_max = 0.0;  ///< largest z displacement of the probe
  bool energy = false;  ///< energies recorded (output.energy)
  /// \var energy_final
  /// Total energy of the last state (energy_initial when energies are not recorded).

  /// \var energy_peak
  /// Largest total energy of any state, the initial one included.

  /// \var energy_max_rise
  /// Largest rise of the total energy in one step (0 when it never rose).

  /// Total energy (kinetic + elastic - external work) of the initial state.
  double energy_initial = 0.0, energy_final = 0.0, energy_peak = 0.0, energy_max_rise = 0.0;
  /// Step of the largest one-step rise (0 when the energy never rose).
  int energy_rise_step = 0;
  /// What the run should flag, in words: a one-step rise of the total energy above
  /// kEnergyRiseTolerance, which implicit Euler, undamped or damped, never has in exact arithmetic.
  std::vector<std::string> warnings;
  /// Number of .vtu frames written (listed in simulation.pvd).
  int frames = 0;
  std::vector<std::string> outputs;  ///< files written
  int failed_step = 0;               ///< 0: every step succeeded
  /// The error message of the failed step (empty when none failed).
  std::string failure;
  bool interrupted = false;          ///< stopped early by the stop flag (set_stop_flag)
  std::vector<StepRecord> records;   ///< step 0 and every step done, as in steps.csv
};

/// The time loop of a dynamic scene (see the file comment). Holds references to the scene and the
/// setup, which must outlive it.
class DynamicRun {
 public:
  /// Builds the step solver and the initial state (nothing is stepped yet). output_dir empty:
  /// nothing is written. setup.notes gains what the run does once or skips. Throws InputError for
  /// a static scene.
  DynamicRun(const Scene& scene, SceneSetup& setup, const std::string& output_dir);
  ~DynamicRun();
  /// The step solver's options as `key=value` pairs (Config::to_string()).
  const std::string& solver_settings() const { return settings_; }
  /// The solver's method ("pmg", "cg", …; "cholmod" for degree 1 with a multigrid method).
  const std::string& method() const { return method_; }
  /// A flag (set by a signal handler, say) that run() reads after every step: when it is non-zero
  /// the run stops after the step in progress, writes its outputs complete and reports
  /// RunSummary::interrupted.
  void set_stop_flag(const volatile std::sig_atomic_t* flag) { stop_ = flag; }
  /// Steps the run plans: the scene's duration / dt, rounded.
  int steps() const { return steps_; }
  /// Runs every step; progress(step, time) after each. A failed step (a solve that fails, a
  /// non-finite state) ends the run: the summary names it, the outputs so far stay written.
  RunSummary run(const std::function<void(int, double)>& progress = {});

 private:
  const Scene& scene_;
  SceneSetup& setup_;
  std::string output_, method_, settings_;
  std::unique_ptr<detail::Stepper> stepper_;
  int steps_ = 0;
  const volatile std::sig_atomic_t* stop_ = nullptr;
};

/// What solve_static() did.
struct StaticOutcome {
  /// The displacement and how the solve went (fem::solve_static).
  fem::StaticResult result;
  /// The solver's method ("cholmod", "pmg", ...).
  std::string method, settings;  ///< the options the solver used, as `key=value` pairs
  /// Wall time of the solve (rotation fixed point included), seconds; set-up and output excluded.
  double seconds = 0.0;
  /// Displacement of the probe in the solution.
  fem::Vec3 probe = fem::Vec3::Zero();
  /// Files written (output_dir/static.vtu; empty when output_dir is empty).
  std::vector<std::string> outputs;
  /// What the solve found beyond u, in words (the mixed formulation: its unknowns and the
  /// pressure's range); empty otherwise.
  std::string summary;
};

/// A static scene: solved by the scene's solver (any method of the factory; CHOLMOD when the scene
/// names none) on the degree hierarchy, a fixed point on the rotations when corotational
/// (fem::solve_static), written to output_dir/static.vtu when output_dir is not empty.
StaticOutcome solve_static(const Scene& scene, SceneSetup& setup, const std::string& output_dir);

}  // namespace pmg::sim
