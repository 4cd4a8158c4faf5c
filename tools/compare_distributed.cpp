// pmg compare --distributed-mesh: the FEM scene built on the ranks (pmg/distributed/mesh_problem.hpp),
// no rank holding the whole model, solved by petsc-mgpcg's PETSc solver; a report of each stage,
// the answer's invariants, the memory of every rank and the ghost/owned ratios.
#include "compare_distributed.hpp"

#include "commands.hpp"

#include "pmg/sim/setup.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/study/study.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

#ifdef PMG_HAVE_DISTRIBUTED
#include "pmg/distributed/mesh_problem.hpp"
#include "pmg/distributed/scene.hpp"
#include "pmg/mpi/session.hpp"
#endif

namespace pmg::tools {

void add_distributed_mesh_options(CLI::App* sub, bool& flag, std::string& save_mesh) {
  sub->add_flag("--distributed-mesh", flag,
                "FEM scenes under mpirun: build the mesh on the ranks (DMPlex; METIS on rank 0, or PT-Scotch for a "
                ".h5 mesh; --refine after distribution), no rank holding the whole model, and solve with petsc-mgpcg "
                "(box or mesh file, degree 2-3, --fix, --load; no reference solve; a --mesh FILE.h5 in PETSc's HDF5 "
                "format is read in parallel)");
  sub->add_option("--save-mesh", save_mesh,
                  "with --distributed-mesh: write the distributed mesh, after --refine, to FILE.h5 (PETSc's HDF5 "
                  "format, every rank its part), for --mesh FILE.h5 to read in parallel");
}

void check_distributed_mesh(const CLI::App& sub, bool on, const std::vector<std::string>& solvers,
                            const std::string& save_mesh) {
  if (!on) {
    if (!save_mesh.empty()) throw InputError("--save-mesh needs --distributed-mesh");
    return;
  }
  for (const char* flag : {"--matrix", "--levels", "--grid", "--dt", "--plot", "--solution-out",
                           "--export-levels", "--export-petsc", "--solver-config", "--fixed-iterations", "--warm-up",
                           "--allow", "--check-every", "--format"})
    if (sub.count(flag))
      throw InputError(std::string("--distributed-mesh does not take ") + flag +
                       " (the scene is built on the ranks and solved by petsc-mgpcg only)");
  for (const auto& s : solvers)
    if (s != "petsc-mgpcg")
      throw InputError("--distributed-mesh runs petsc-mgpcg only (the other methods need the whole model on one "
                       "process), not " + s);
  if (!save_mesh.empty() && (save_mesh.size() <= 3 || save_mesh.compare(save_mesh.size() - 3, 3, ".h5") != 0))
    throw InputError("--save-mesh " + save_mesh + ": PETSc's HDF5 mesh format, a name ending in .h5");
}

#ifdef PMG_HAVE_DISTRIBUTED
namespace {

std::string gib(double bytes) {
  char s[32];
  std::snprintf(s, sizeof s, "%.2f GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return s;
}

std::string seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f s", s);
  return b;
}

/// Per rank: the values gathered on every rank.
std::vector<double> gathered(MPI_Comm comm, double mine) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  std::vector<double> all(size);
  MPI_Allgather(&mine, 1, MPI_DOUBLE, all.data(), 1, MPI_DOUBLE, comm);
  return all;
}

/// Rank 0 writes --history and --json.
void write_outputs(const DistributedMeshOutputs& out, MPI_Comm comm, const std::string& system,
                   const dist::MeshProblem& problem, const dist::RankSolveReport& r, const nlohmann::ordered_json& stages,
                   const nlohmann::ordered_json& peaks, const std::vector<double>& memory) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  if (rank != 0) return;
  if (!out.history.empty()) {
    study::SolverRun run;  // the CSV of pmg compare --history: seconds from the start of the set-up
    run.name = "petsc-mgpcg";
    run.setup_s = r.setup_seconds;
    run.history = r.history;
    study::write_history(out.history, {run});
  }
  if (out.json.empty()) return;
  nlohmann::ordered_json j;
  j["system"] = system;
  j["ranks"] = size;
  j["tets"] = problem.global_cells();
  j["unknowns"] = r.unknowns;
  j["stages"] = stages;
  j["iterations"] = r.result.iterations;
  j["converged"] = r.result.ok();
  j["true_relative_residual"] = r.true_residual;
  j["compliance (J)"] = r.compliance;
  j["largest displacement (m)"] = r.max_displacement;
  j["peak resident memory per rank (bytes)"] = memory;
  j["largest rank's peak resident memory after each stage (bytes)"] = peaks;
  nlohmann::ordered_json ghosts = nlohmann::ordered_json::array();
  for (const auto& [g, n] : r.ghosts.front()) ghosts.push_back({{"ghosts", g}, {"owned", n}});
  j["finest level ghost/owned nodes per rank"] = ghosts;
  write_file_atomically(out.json, j.dump(2) + "\n");
}

}  // namespace

void run_distributed_mesh(const SceneOptions& o, const Config& solver, const DistributedMeshOutputs& out) {
  mpi::start();
  MPI_Comm comm = MPI_COMM_WORLD;
  int size = 1;
  MPI_Comm_size(comm, &size);
  (void)solver.get_string("method", "petsc-mgpcg");  // the route's one method, chosen by the caller
  dist::DistributedMgpcgParams params = read_params<dist::DistributedMgpcgParams>(solver);
  params.allow_unused_options = unused_options_allowed(solver);
  check_keys_used(solver);

  const sim::Scene scene = scene_of(o);
  dist::MeshProblemOptions mp = dist::mesh_problem_options(scene);
  mp.save_mesh = out.save_mesh;
  long coarse_cells = 0;
  std::vector<std::string> warnings;
  const std::unique_ptr<dist::MeshProblem> made = dist::mesh_problem(comm, scene, mp, &warnings, &coarse_cells);
  for (const auto& w : warnings) std::cerr << "warning: " << w << "\n";
  const bool parallel_read = dist::is_plex_file(o.mesh);
  dist::MeshProblem& problem = *made;
  Vector x;
  const dist::RankSolveReport r = dist::solve_on_ranks(problem, params, x);
  const std::vector<double> memory = gathered(comm, dist::peak_resident_bytes());

  std::ostringstream sys;
  sys << (o.mesh.empty() ? "box bar " + std::to_string(o.box[0]) + "x" + std::to_string(o.box[1]) + "x" +
                               std::to_string(o.box[2]) + " boxes"
                         : o.mesh)
      << ", degree " << o.degree << ", distributed mesh (DMPlex): "
      << (parallel_read ? std::string("read in parallel, ") : std::to_string(coarse_cells) + " tets on rank 0, ")
      << (size == 1 ? "on 1 rank" : std::string(parallel_read ? "partitioned by PT-Scotch over " : "partitioned by METIS on rank 0 over ") + std::to_string(size) + " ranks");
  if (o.refine > 0) sys << ", refined " << o.refine << "x on the ranks";
  sys << ": " << problem.global_cells() << " tets, " << r.unknowns << " unknowns, " << problem.clamped_vertices()
      << " clamped vertices, ";
  if (problem.held_components() > 0) sys << problem.held_components() << " components held by symmetry planes, ";
  sys << o.load;
  std::cout << "system: " << sys.str() << "\n";
  std::cout << "stages (time of the slowest rank; peak resident memory of the largest rank so far):\n";
  nlohmann::ordered_json stages = nlohmann::ordered_json::object(), peaks = nlohmann::ordered_json::object();
  const auto largest = [&](double mine) {
    double most = 0.0;
    MPI_Allreduce(&mine, &most, 1, MPI_DOUBLE, MPI_MAX, comm);
    return most;
  };
  double building = 0.0;
  for (size_t k = 0; k < problem.stages().size(); ++k) {
    const auto& [name, s] = problem.stages()[k];
    const double slowest = largest(s), peak = largest(problem.stage_peaks()[k]);
    std::cout << "  " << name << ": " << seconds(slowest) << ", " << gib(peak) << "\n";
    stages[name + " (s)"] = slowest;
    peaks[name] = peak;
    building += slowest;
  }
  const double after_setup = largest(r.peak_after_setup), after_solve = largest(r.peak_after_solve);
  std::cout << "  petsc-mgpcg set-up: " << seconds(r.setup_seconds) << ", " << gib(after_setup) << " (rank 0:";
  for (const auto& [name, s] : r.setup_stages.parts) std::cout << " " << name << " " << seconds(s) << ";";
  std::cout << ")\n  solve: " << seconds(r.solve_seconds) << ", " << gib(after_solve) << "\n";
  peaks["petsc-mgpcg set-up"] = after_setup;
  peaks["solve"] = after_solve;
  char tol[32];
  std::snprintf(tol, sizeof tol, "%g", params.tol);
  std::cout << "t(" << tol << "): set-up + solve " << seconds(r.setup_seconds + r.solve_seconds)
            << "; the whole job (mesh to answer) " << seconds(building + r.setup_seconds + r.solve_seconds) << "\n";
  stages["petsc-mgpcg set-up (s)"] = r.setup_seconds;
  stages["solve (s)"] = r.solve_seconds;
  char line[256];
  std::snprintf(line, sizeof line,
                "petsc-mgpcg: %s in %d iterations, true relative residual %.2e; compliance b.u = %.10e J, "
                "largest displacement %.6e m\n",
                r.result.ok() ? "converged" : "stopped", r.result.iterations, r.true_residual, r.compliance,
                r.max_displacement);
  std::cout << line;
  std::cout << "levels: " << r.description << "\n";
  double most = 0.0, least = 1e300, sum = 0.0;
  for (double m : memory) most = std::max(most, m), least = std::min(least, m), sum += m;
  std::cout << "peak resident memory per rank: " << gib(most) << " largest, " << gib(least) << " smallest, "
            << gib(sum) << " in all\n";
  std::cout << "ghost/owned nodes, finest level:";
  for (const auto& [ghosts, owned] : r.ghosts.front()) std::cout << " " << ghosts << "/" << owned;
  std::cout << "\n";
  if (size > 2) std::cout << "(more ranks than cores measure overhead, not speed-up)\n";

  write_outputs(out, comm, sys.str(), problem, r, stages, peaks, memory);
  if (!r.result.ok()) throw Exit{kSolveFailed};
}

#else

void run_distributed_mesh(const SceneOptions&, const Config&, const DistributedMeshOutputs&) {
  throw InputError("--distributed-mesh: this build has no PETSc (pmg::distributed is not built)");
}

#endif

}  // namespace pmg::tools
