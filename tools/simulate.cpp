// pmg simulate [scene.json]: a dynamic (or static) corotational simulation of a JSON scene; with
// no file, the built-in default scene (a cubic cantilever released from a deflected state). The
// scene, its set-up and its run are pmg::sim's; this prints them (and --json writes them).
#include "checks.hpp"
#include "commands.hpp"
#include "ranks.hpp"
#include "scene.hpp"

#include "pmg/mpi/session.hpp"
#include "table.hpp"

#include "pmg/sim/run.hpp"
#include "pmg/sim/scene.hpp"
#include "pmg/sim/setup.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/timer.hpp"

#include <mpi.h>
#include <nlohmann/json.hpp>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <string>

namespace pmg::tools {

namespace {


using json = nlohmann::json;

struct Cli {
  std::string scene, output, json_report;
  double duration = 0, dt = 0;
  bool print_scene = false, quiet = false;
  bool render = false;  // --render: the output folder's frames into <output>/render/ at the end
  bool distributed_mesh = false;  // --distributed-mesh: no rank holds the whole mesh
};

/// Whether the progress may redraw one line with '\r': standard output is a terminal and no MPI
/// launcher started this process (mpirun hands its ranks a pseudo-terminal whatever its own output
/// is, so a log file would collect every redraw).
bool progress_on_terminal() {
  for (const char* launcher : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "SLURM_STEP_NUM_TASKS"})
    if (std::getenv(launcher)) return false;
  return isatty(fileno(stdout)) == 1;
}

/// Progress of a dynamic run: on a terminal one line redrawn with '\r' (a bar, step, time, ETA);
/// otherwise a plain line every 10% of the steps.
class Progress {
 public:
  Progress(int total, bool quiet) : total_(total), quiet_(quiet), tty_(progress_on_terminal()), t0_(Clock::now()) {}
  void update(int step, double t) {
    if (quiet_) return;
    const double elapsed = seconds_since(t0_);
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

json vec3(const fem::Vec3& v) { return {v.x(), v.y(), v.z()}; }


void run_static(const sim::Scene& s, sim::SceneSetup& b, const Cli& cli, json& report) {
  const sim::StaticOutcome r = sim::solve_static(s, b, cli.output);
  std::cout << "solver:  " << r.settings << "\n"
            << "static solve (" << r.method << (s.corotational ? ", corotational fixed point" : "") << "): "
            << r.result.iterations << " iteration(s)"
            << (r.method == "cholmod" ? std::string() : ", " + std::to_string(r.result.solver_iterations) + " solver iterations")
            << ", " << fmt("%.3f", r.seconds) << " s\n"
            << (r.summary.empty() ? std::string() : r.summary + "\n")
            << "probe (" << b.probe.point.transpose() << ") displacement: " << r.probe.transpose() << "\n"
            << "skipped: mass matrix, time loop (static scene)\n";
  report["static"] = {{"solver", r.method}, {"settings", r.settings}, {"iterations", r.result.iterations},
                      {"solver_iterations", r.result.solver_iterations}, {"seconds", r.seconds}};
  if (!r.summary.empty()) report["static"]["summary"] = r.summary;
  report["probe"] = {{"point_m", vec3(b.probe.point)}, {"displacement_m", vec3(r.probe)}};
  for (const auto& f : r.outputs) std::cout << "wrote " << f << "\n";
  if (!r.outputs.empty()) report["outputs"] = r.outputs;
}

void run_dynamic(const sim::Scene& s, sim::SceneSetup& b, const Cli& cli, json& report) {
  sim::DynamicRun run(s, b, cli.output);
  run.set_stop_flag(interrupt_flag());
  const std::string& method = run.method();
  std::cout << "time:    " << run.steps() << " steps of " << s.dt << " s (" << s.duration << " s), implicit Euler"
            << (s.rayleigh_alpha > 0 || s.rayleigh_beta > 0 ? ", Rayleigh damping" : ", undamped") << "\n"
            << "solver:  " << run.solver_settings() << " per step, warm start (where it beats zero)\n\n";
  Progress progress(run.steps(), cli.quiet);
  const sim::RunSummary r = run.run([&](int step, double t) { progress.update(step, t); });
  if (r.failed_step) progress.interrupt();

  const int done = r.steps_done;
  Table t({"stage", "total [s]", "per step [ms]", "share"});
  double sum = r.output_s;
  for (double x : r.stage_s) sum += x;
  auto row = [&](const std::string& name, double total) {
    t.add({name, fmt("%.3f", total), fmt("%.3f", 1e3 * total / std::max(done, 1)), fmt("%.1f%%", 100 * total / sum)});
  };
  for (int k = 0; k < fem::kNumStages; ++k)
    if (r.stage_s[k] > 0) row(fem::stage_name(k), r.stage_s[k]);
  if (!cli.output.empty()) row("output", r.output_s);
  std::cout << "\n";
  t.print(std::cout);
  const double E0 = r.energy_initial, E1 = r.energy_final;
  std::cout << "\nsteps:   " << done << " in " << fmt("%.2f", r.wall_s) << " s wall, " << fmt("%.2f", done > 0 ? static_cast<double>(r.iterations) / done : 0.0)
            << " " << (method == "pmg" ? "cycles" : "iterations") << " per step (max " << r.max_iterations
            << "), largest ||b - Av|| / ||b|| " << fmt("%.1e", r.max_residual) << "\n"
            << "probe:   (" << b.probe.point.transpose() << "): displacement now " << r.probe.transpose() << ", z range ["
            << fmt("%.4f", r.probe_z_min) << ", " << fmt("%.4f", r.probe_z_max) << "] m\n";
  if (r.energy)
    std::cout << "energy:  " << fmt("%.6g", E0) << " J at t = 0, " << fmt("%.6g", E1) << " J at t = " << fmt("%.3f", done * s.dt)
              << " s (" << fmt("%+.2f%%", E0 != 0 ? 100 * (E1 - E0) / std::abs(E0) : 0.0) << "); peak "
              << fmt("%.3e", E0 != 0 ? (r.energy_peak - E0) / std::abs(E0) : 0.0) << " above the start, largest one-step rise "
              << fmt("%.2e", r.energy_max_rise) << " J\n";
  for (const auto& note : b.notes) std::cout << "note:    " << note << "\n";
  for (const auto& w : r.warnings) std::cerr << "warning: " << w << "\n";
  if (!r.outputs.empty()) {
    std::cout << "output:  " << r.outputs[0];
    if (r.outputs.size() > 1) std::cout << ", " << r.outputs[1] << " (" << r.frames << " frames)";
    std::cout << "\n";
  }

  report["time"] = {{"dt_s", s.dt}, {"duration_s", s.duration}, {"steps_planned", r.steps_planned}};
  report["solver"] = {{"method", method}, {"settings", run.solver_settings()}};
  json stages = json::array();
  for (int k = 0; k < fem::kNumStages; ++k)
    stages.push_back({{"stage", fem::stage_name(k)}, {"total_s", r.stage_s[k]}, {"per_step_ms", 1e3 * r.stage_s[k] / std::max(done, 1)}});
  if (!cli.output.empty())
    stages.push_back({{"stage", "output"}, {"total_s", r.output_s}, {"per_step_ms", 1e3 * r.output_s / std::max(done, 1)}});
  report["stages"] = stages;
  report["steps"] = {{"done", done},
                     {"wall_s", r.wall_s},
                     {"iterations_per_step", done > 0 ? static_cast<double>(r.iterations) / done : 0.0},
                     {"max_iterations", r.max_iterations},
                     {"iterations_are", method == "pmg" ? "cycles" : "iterations"},
                     {"largest_residual_b", r.max_residual}};
  report["probe"] = {{"point_m", vec3(b.probe.point)}, {"displacement_m", vec3(r.probe)}, {"z_range_m", {r.probe_z_min, r.probe_z_max}}};
  if (r.energy)
    report["energy"] = {{"initial_J", E0}, {"final_J", E1}, {"peak_J", r.energy_peak}, {"largest_step_rise_J", r.energy_max_rise}};
  if (!r.outputs.empty()) report["outputs"] = r.outputs;
  report["notes"] = b.notes;
  report["warnings"] = r.warnings;
  if (r.interrupted) {
    progress.interrupt();
    const std::string where = cli.output.empty() ? "nothing was written (no output folder)"
                                                 : "steps.csv" + std::string(r.frames ? " and " + std::to_string(r.frames) + " frames" : "") +
                                                       " in " + cli.output + " are complete";
    report["interrupted"] = {{"step", done}, {"time_s", done * s.dt}};
    std::cout << "\ninterrupted after step " << done << " of " << r.steps_planned << " (t = " << fmt("%.3f", done * s.dt)
              << " s): " << where << "\n";
    throw Exit{kInterrupted};
  }
  if (r.failed_step) {
    report["failure"] = {{"step", r.failed_step}, {"message", r.failure}};
    std::cout << std::flush;
    std::cerr << "\npmg: error: simulation failed at step " << r.failed_step << ": " << r.failure << "\n";
    throw Exit{kSolveFailed};
  }
}

/// The scene's mesh in words: its source, size, degree and clamp.
std::string mesh_line(const sim::Scene& s, const sim::SceneSetup& b) {
  std::string line = (s.mesh_file.empty() ? "box bar " + std::to_string(s.box[0]) + "x" + std::to_string(s.box[1]) + "x" +
                                                std::to_string(s.box[2]) + " boxes"
                                          : s.mesh_file) +
                     (s.refine > 0 ? " refined " + std::to_string(s.refine) + "x" : "");
  if (b.on_ranks) {
    const sim::RankMeshSummary& r = b.rank_mesh;
    return line + (s.refine > 0 ? " on the ranks" : "") + ", " + std::to_string(r.cells) + " tets, degree " +
           std::to_string(s.degree) + ", " + std::to_string(r.unknowns) + " unknowns, " +
           std::to_string(r.clamped_vertices) + " clamped vertices; distributed over " + count_of(r.ranks, "rank") +
           (r.coarse_cells > 0 ? " from " + std::to_string(r.coarse_cells) + " cells on rank 0"
                               : " (read in parallel)");
  }
  const fem::ElasticityModel& m = b.finest();
  return line + ", " + std::to_string(b.mesh->num_tets()) + " tets, degree " + std::to_string(s.degree) + ", " +
         std::to_string(m.num_free_dofs()) + " unknowns, " + std::to_string(m.num_fixed()) + " clamped nodes" +
         (s.supports.empty() ? std::string() : ", " + std::to_string(held_components(m)) + " components held by supports");
}

/// The report's "mesh" object.
json mesh_report(const sim::Scene& s, const sim::SceneSetup& b) {
  json j = {{"source", s.mesh_file.empty() ? "box" : s.mesh_file}, {"degree", s.degree}};
  if (b.on_ranks) {
    const sim::RankMeshSummary& r = b.rank_mesh;
    j.update({{"tets", r.cells}, {"unknowns", r.unknowns}, {"clamped_vertices", r.clamped_vertices},
              {"distributed", {{"ranks", r.ranks}, {"coarse_cells_rank0", r.coarse_cells}}}});
    json stages = json::array();
    for (const auto& [name, seconds] : r.stages) stages.push_back({{"stage", name}, {"seconds_rank0", seconds}});
    j["distributed"]["setup_stages"] = stages;
  } else {
    j.update({{"tets", b.mesh->num_tets()}, {"unknowns", b.finest().num_free_dofs()}, {"clamped_nodes", b.finest().num_fixed()}});
  }
  return j;
}

void run(const Cli& cli_in) {
  catch_interrupt();
  Cli cli = cli_in;
  sim::Scene s = cli.scene.empty() ? sim::Scene{} : sim::read_scene(cli.scene);
  if (cli.scene.empty()) s.initial = "deflected";  // the default scene: a released cantilever
  if (cli.duration > 0) s.duration = cli.duration;
  if (cli.dt > 0) s.dt = cli.dt;
  if (s.dynamic && (cli.duration > 0 || cli.dt > 0))
    if (const std::string why = s.check_time(); !why.empty())
      throw InputError(std::string(cli.dt > 0 && cli.duration > 0 ? "--dt, --duration"
                                   : cli.duration > 0              ? "--duration"
                                                                   : "--dt") + ": " + why);
  const bool output_from_cli = !cli.output.empty();
  if (cli.output.empty()) cli.output = s.output;
  if (cli.print_scene) {
    std::cout << sim::scene_to_json(s);
    return;
  }
  // --render needs frames to render: refused before any work, as a bad path is.
  if (cli.render && cli.output.empty())
    throw InputError("--render renders the run's frames, and this run writes none: give -o DIR (or "
                     "output.directory in the scene)");
  if (cli.render && s.dynamic && s.frame_every == 0)
    throw InputError("--render: " + s.source + ": output.frame_every is 0, so the run writes no frames to render");
  const std::string render_dir = cli.render ? (std::filesystem::path(cli.output) / "render").string() : std::string();
  // Output paths are checked before any work: a run must not fail at its end for a bad path.
  if (!cli.output.empty())
    prepare_output_directory(cli.output, output_from_cli ? "-o" : s.source + ": output.directory");
  FilePlan plan;  // no output may be an input or another output
  sim::plan_files(s, cli.scene, cli.output, plan);
  plan.output(cli.json_report, "--json");
  plan.check();
  if (cli.render && mpi::launched_rank() == 0) prepare_output_directory(render_dir, "--render");
  const bool across_ranks = cli.distributed_mesh || sim::runs_across_ranks(s);
  if (mpi::launched_rank() != 0) {  // under mpirun rank 0 writes; every rank its piece of a distributed frame
    cli.json_report.clear();
    if (!across_ranks) cli.output.clear();
  }
  const auto t0 = Clock::now();
  sim::SceneSetup b = cli.distributed_mesh ? sim::set_up_on_ranks(s) : sim::set_up(s);
  for (const auto& w : b.warnings) std::cerr << "warning: " << w << "\n";
  std::cout << "scene:   " << s.source << "\n"
            << "mesh:    " << mesh_line(s, b) << "\n"
            << "model:   " << (s.corotational ? "corotational" : "linear") << ", E = " << s.young << " Pa, nu = " << s.poisson
            << ", rho = " << s.density << " kg/m^3; initial state " << s.initial << "\n"
            << "set-up:  " << fmt("%.3f", seconds_since(t0)) << " s, " << count_of(omp_get_max_threads(), "thread") << "\n";
  json report = {{"command", "pmg simulate"},
                 {"scene", s.source},
                 {"mesh", mesh_report(s, b)},
                 {"model", {{"material", s.corotational ? "corotational" : "linear"},
                            {"young_Pa", s.young},
                            {"poisson", s.poisson},
                            {"density_kg_m3", s.density},
                            {"initial_state", s.initial}}},
                 {"setup_s", seconds_since(t0)},
                 {"threads", omp_get_max_threads()}};
  auto write_report = [&] {
    if (!cli.json_report.empty()) write_file_atomically(cli.json_report, report.dump(2) + "\n");
  };
  try {
    if (s.dynamic) run_dynamic(s, b, cli, report);
    else run_static(s, b, cli, report);
  } catch (const Exit&) {  // a failed or interrupted run: the report says where and why
    write_report();
    throw;
  }
  write_report();
  // Under mpirun rank 0 renders: a run across the ranks once every rank has written its pieces of
  // the last frame (another run's frames are all rank 0's own).
  if (cli.render && mpi::launched_ranks() > 1 && across_ranks) {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Barrier(MPI_COMM_WORLD);
  }
  if (cli.render && mpi::launched_rank() == 0) {
    try {
      render_frames(cli.output, render_dir, RenderOptions{});
    } catch (const Error& e) {  // the run itself succeeded: its outputs stay
      throw Error(std::string("--render: ") + e.what() + " (the run's outputs in " + cli.output + " are complete)");
    }
  }
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto cli = std::make_shared<Cli>();
  auto* sub = app.add_subcommand("simulate", "run a simulation scene (JSON); no file: the built-in cantilever");
  sub->add_option("scene", cli->scene, "scene file (JSON)")->check(CLI::ExistingFile);
  sub->add_option("-o,--output", cli->output, "write steps.csv and .vtu frames here (overrides output.directory)");
  sub->add_flag("--render", cli->render,
                "at the end, render the frames to PNG stills and an animated GIF in OUTPUT/render/ (as pmg render "
                "does; needs -o or output.directory)");
  sub->add_option("--duration", cli->duration, "override time.duration [s]")->check(FinitePositive());
  sub->add_option("--dt", cli->dt, "override time.dt [s]")->check(FinitePositive());
  add_threads_option(sub);
  sub->add_flag("--distributed-mesh", cli->distributed_mesh,
                "under mpirun: build the scene on the ranks, none holding the whole mesh (DMPlex; a .h5 mesh read in "
                "parallel, mesh.refine after distribution), and step or solve it with petsc-mgpcg (docs/distributed.md)");
  sub->add_flag("--print-scene", cli->print_scene, "print the scene as JSON (a template to edit) and stop");
  sub->add_flag("-q,--quiet", cli->quiet, "no progress lines");
  sub->add_option("--json", cli->json_report,
                  "also write every figure of the report to this JSON file (units in the key names)");
  sub->callback([cli, sub] {
    agree_across_ranks(*sub, {cli->scene});
    run(*cli);
  });
}

}  // namespace pmg::tools
