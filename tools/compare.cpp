// pmg compare — runs several solvers on the same system and reports residual against time.
//
//   1. Load the system: a Matrix Market matrix (+ optional right-hand side and known solution), an
//      FEM scene (mesh or box bar, degree, material, supports, load: the only systems on which PMG
//      and MGPCG can run, since they need the degree hierarchy), or the built-in spring lattice
//      with a manufactured solution.
//   2. Convert once to the formats the solvers need (CSR, BCSR 3x3, BIN-BCSR).
//   3. For each solver: set up (timed), solve from x = 0 (timed, monitored), compute the true error.
//   4. Print the summary table; write the per-iteration history as CSV (--history) and draw the
//      plot (--plot: from the history and a per-solver summary, temporary files unless --history).
#include "process.hpp"
#include "compare_distributed.hpp"
#include "compare_mixed.hpp"
#include "compare_plot.hpp"
#include "ranks.hpp"
#include "pmg/sparse/defaults.hpp"
#include "checks.hpp"
#include "commands.hpp"
#include "levels.hpp"
#include "scene.hpp"
#include "table.hpp"

#include "pmg/sparse/layout.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/multigrid/user_levels.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/study/study.hpp"

#include <filesystem>
#include <sys/wait.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/generators.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/matrix_market.hpp"
#include "pmg/sparse/petsc_binary.hpp"
#include "pmg/sparse/timer.hpp"

#include <omp.h>

#include <cstdlib>
#include <fstream>
#include <set>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <tuple>
#include <memory>
#include <sstream>

namespace pmg::tools {

namespace {


struct Options {
  std::string matrix, rhs, solution, history, plot, export_levels, export_petsc, json_report;
  std::vector<std::string> levels, prolongations;  // user multigrid levels (Matrix Market or PETSc binary)
  std::string layout = "interleaved", solution_out;
  bool galerkin_from_finest = false;
  int grid = 24;
  bool fem = false;  // set when a scene option is given
  SceneOptions scene;
  bool reference = true;
  bool distributed_mesh = false;  // --distributed-mesh: the scene built on the ranks (DMPlex)
  std::string save_mesh;          // --save-mesh FILE.h5: that route's refined mesh, in parallel
  std::vector<std::string> solvers;  // default depends on the system
  std::vector<std::string> overrides;  // --set key=value, for every solver of the run
  std::string solver_config;           // --solver-config FILE.json: named configurations
  std::string format = "bcsr";      // csr where --matrix reads as a scalar system and --format is not given
  std::string block_size = "auto";  // --matrix: auto (from the pattern) | 1 | 3
  double tol = 1e-8;
  int max_iterations = 20000;
  int fixed_iterations = 0;
  int check_every = 1;
  bool warm_up = false;
  std::string formulation = "displacement";  // mixed: the displacement-pressure system (compare_mixed)
  std::set<std::string> given;  // the stopping flags given on the command line
};

/// Whether `method` takes the stopping flag of solver key `key` (tol, max_iterations, ...): the
/// iterative methods, those with an iteration limit.
bool reads_stopping_flag(const std::string& method, const char* key) {
  return method_accepts_key(method, "max_iterations") && method_accepts_key(method, key);
}

/// One solver's options from the command line: its method and the stopping flags where the
/// method reads them (solver options beyond those come from --set and --solver-config).
Config cli_config(const Options& o, const std::string& method) {
  Config c = Config::from_pairs({"method=" + method}, "pmg compare (" + method + ")");
  auto accepts = [&](const char* k) { return method_accepts_key(method, k); };
  // --tol is the stopping rule of the iterative methods; a direct solver checks its answer against
  // its own tol (--set tol=...), which rounding on ill-conditioned systems must be able to meet.
  if (reads_stopping_flag(method, "tol")) c.set("tol", fmt("%.17g", o.tol));
  if (o.fixed_iterations > 0 && accepts("fixed_iterations"))
    c.set("fixed_iterations", std::to_string(o.fixed_iterations));
  else if (accepts("max_iterations"))
    c.set("max_iterations", std::to_string(o.max_iterations));
  if (accepts("check_every") && o.check_every != 1) c.set("check_every", std::to_string(o.check_every));
  if (o.galerkin_from_finest && accepts("coarse_operator")) c.set("coarse_operator", "galerkin");
  return c;
}

/// Every solver of the run with its options: --solver-config's named configurations, else the
/// --solvers list from the command-line flags; --set overrides go to each.
std::vector<std::pair<std::string, Config>> solver_configs(const Options& o, const std::vector<std::string>& names,
                                                           const Config& set) {
  std::vector<std::pair<std::string, Config>> out;
  if (!o.solver_config.empty()) {
    const std::string text = read_text_file(o.solver_config, kMaxConfigBytes, "--solver-config");
    check_json_text(text, o.solver_config);  // syntax, duplicate keys, out-of-range numbers
    const nlohmann::ordered_json j = nlohmann::ordered_json::parse(text);
    if (!j.is_object() || j.empty())
      throw InputError(o.solver_config + ": expected an object of named solver configurations "
                       "({\"name\": {\"method\": ...}, ...})");
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (!it.value().is_object())
        throw InputError(o.solver_config + ": " + it.key() + ": expected an object of solver options");
      Config c = Config::from_json(it.value().dump(), o.solver_config + ": " + it.key());
      const std::string method = c.get_string("method", kDefaultMethod);
      if (reads_stopping_flag(method, "tol")) c.set_default("tol", fmt("%.17g", o.tol));
      out.emplace_back(it.key(), c);
    }
  } else {
    for (const auto& n : names) out.emplace_back(n, cli_config(o, n));
  }
  for (auto& nc : out) nc.second.merge(set);
  return out;
}

struct System {
  std::string description;
  Csr csr;                            // scalar entries: kept only where a solve reads them
  std::shared_ptr<const Bcsr> bcsr;   // when the size is a multiple of 3 (FEM: the hierarchy's own)
  Vector b, x_true;            // x_true empty when unknown
  std::unique_ptr<FemSystem> fem;
  std::unique_ptr<mg::UserLevels> levels;
  Vector b_full;  // user levels: b as given, identity rows included (levels->reduce(b_full) = b)
  double user_levels_s = -1;  // user levels: seconds to turn the matrices read into the cycle's levels
  std::string error_reference = "known solution";
  bool reference_pending = false;  // FEM: x_true is a direct solve made after the timed runs
  index_t unknowns() const { return bcsr ? bcsr->rows() : fem ? static_cast<index_t>(b.size()) : csr.rows(); }
  /// The finest matrix's nonzeros and 3x3 blocks; -1 where it was not assembled (FEM, matrix-free
  /// solvers only).
  offset_t nonzeros() const { return bcsr ? 9 * static_cast<offset_t>(bcsr->num_blocks()) : fem ? -1 : csr.nnz(); }
  offset_t blocks() const { return bcsr ? static_cast<offset_t>(bcsr->num_blocks()) : -1; }
};

/// A non-owning pointer to a matrix that outlives the system's users (the FEM hierarchy's).
std::shared_ptr<const Bcsr> borrow(const Bcsr& A) { return std::shared_ptr<const Bcsr>(std::shared_ptr<void>(), &A); }


/// Files ending in .petsc are PETSc's binary format, others Matrix Market.
bool is_petsc_file(const std::string& path) {
  return path.size() > 6 && path.compare(path.size() - 6, 6, ".petsc") == 0;
}
Csr read_any_matrix(const std::string& path) {
  return is_petsc_file(path) ? read_petsc_binary_matrix(path) : read_matrix_market(path);
}
Vector read_any_vector(const std::string& path) {
  return is_petsc_file(path) ? read_petsc_binary_vector(path) : read_matrix_market_vector(path);
}

System load_system(const Options& o) {
  System s;
  if (!o.levels.empty()) {
    // Levels as FEM codes write them (mg::UserLevels): either layout, node or dof prolongations,
    // Dirichlet identity rows removed; Matrix Market or PETSc binary (.petsc, loads at disk speed).
    std::vector<Csr> mats, ps;
    for (const auto& f : o.levels) mats.push_back(read_any_matrix(f));
    for (const auto& f : o.prolongations) ps.push_back(read_any_matrix(f));
    std::vector<CsrView> mv, pv;
    for (const auto& m : mats) mv.push_back(view_of(m));
    for (const auto& p : ps) pv.push_back(view_of(p));
    mg::UserLevelOptions lo;
    lo.layout = mg::parse_layout(o.layout);
    lo.galerkin_only = o.galerkin_from_finest;
    const auto t0 = Clock::now();
    s.levels = std::make_unique<mg::UserLevels>(mv, pv, lo);
    s.user_levels_s = seconds_since(t0);
    s.bcsr = borrow(s.levels->matrix(s.levels->num_levels() - 1));
    if (o.format == "csr") s.csr = s.bcsr->to_csr();
    s.description = "user levels, finest " + o.levels.back();
    if (!o.rhs.empty()) {
      s.b_full = read_any_vector(o.rhs);
      s.b = s.levels->reduce(s.b_full);
    } else {
      s.x_true = Vector::LinSpaced(s.bcsr->rows(), 1.0, 2.0);
      s.b.resize(s.x_true.size());
      s.bcsr->multiply(s.x_true.data(), s.b.data());
      s.b_full = s.levels->expand(s.b, Vector::Zero(s.levels->full_size()));  // zero on identity rows
    }
    if (s.levels->removed_nodes().back() > 0)
      s.description += " (" + std::to_string(s.levels->removed_nodes().back()) + " clamped nodes removed)";
  } else if (!o.matrix.empty()) {
    s.csr = read_matrix_market(o.matrix);
    if (s.csr.rows() != s.csr.cols())
      throw InputError(o.matrix + ": matrix is " + std::to_string(s.csr.rows()) + "x" +
                       std::to_string(s.csr.cols()) + "; the solvers need a square matrix");
    if (!s.csr.is_symmetric(1e-12))
      throw InputError(o.matrix + ": matrix is not symmetric; CG and Cholesky need an SPD matrix");
    s.description = o.matrix;
    if (!o.solution.empty()) s.x_true = read_matrix_market_vector(o.solution);
    if (!o.rhs.empty()) {
      s.b = read_matrix_market_vector(o.rhs);
    } else {
      // No right-hand side: manufacture one from a known solution so the error can be reported.
      if (s.x_true.size() == 0) s.x_true = Vector::LinSpaced(s.csr.rows(), 1.0, 2.0);
      s.b = s.csr.to_eigen() * s.x_true;
    }
    if (s.b.size() != s.csr.rows())
      throw InputError("right-hand side has " + std::to_string(s.b.size()) + " entries, matrix has " +
                       std::to_string(s.csr.rows()) + " rows");
    if (s.x_true.size() != 0 && s.x_true.size() != s.csr.rows())
      throw InputError("solution has " + std::to_string(s.x_true.size()) +
                       " entries, matrix has " + std::to_string(s.csr.rows()) + " rows");
    if (s.csr.rows() % 3 == 0) {
      // Judged on the scalar matrix, before it becomes blocks (pmg/sparse/layout.hpp).
      const std::string reading = component_major_reading(s.csr);
      const bool layout_given =
          std::any_of(o.overrides.begin(), o.overrides.end(), [](const std::string& kv) { return kv.rfind("layout=", 0) == 0; });
      if (!reading.empty() && !layout_given)
        std::cerr << "warning: " << reading << "; the block methods read 3x3 blocks of interleaved unknowns: add "
                  << "--set layout=component\n";
    }
    // 3x3 blocks where the data carries them (pmg::reads_as_blocks) or --block-size 3 says so; a
    // scalar system stays CSR and runs the scalar methods.
    if (o.block_size == "3" && s.csr.rows() % 3 != 0)
      throw InputError("--block-size 3: the size " + std::to_string(s.csr.rows()) + " is not divisible by 3");
    if (o.block_size == "3" || (o.block_size == "auto" && reads_as_blocks(s.csr)))
      s.bcsr = std::make_shared<const Bcsr>(Bcsr::from_csr(s.csr));
  } else if (o.fem) {
    // The finest matrix is assembled here only where the options read it (a reference solve,
    // exports, another format); otherwise run() assembles it once a solver that is not
    // matrix-free asks for it.
    const bool finest = o.reference || !o.export_levels.empty() || !o.export_petsc.empty() || o.format != "bcsr";
    s.fem = std::make_unique<FemSystem>(build_fem_system(o.scene, finest));
    if (finest) s.bcsr = borrow(s.fem->matrix());  // the hierarchy's matrix itself, not a copy
    if (o.format == "csr") s.csr = s.bcsr->to_csr();
    s.b = s.fem->b;
    s.description = s.fem->description;
    // The error column is measured against a direct solve, made after the timed runs (or taken
    // from the run's own cholmod solver): no second factorisation held while the others run.
    s.reference_pending = o.reference;
  } else {
    // Measured peaks of a compare run: about 15 KB per lattice node (--grid 20 and 40); 8 KB is
    // the lower estimate that refuses only what cannot fit.
    const double nodes = std::pow(static_cast<double>(o.grid), 3);
    require_memory(8e3 * nodes, "--grid " + std::to_string(o.grid) + " (" + fmt("%.3g", nodes) + " nodes)");
    s.bcsr = std::make_shared<const Bcsr>(spring_lattice(o.grid));
    s.csr = s.bcsr->to_csr();
    s.x_true = smooth_field(o.grid);
    s.b = s.csr.to_eigen() * s.x_true;
    s.description = "built-in spring lattice " + std::to_string(o.grid) + "^3 (27-point 3x3-block "
                    "stencil, z=0 face fixed)";
  }
  return s;
}

/// The operator the Krylov solvers multiply with, in the requested format.
struct Formats {
  const LinearOperator* op = nullptr;
  std::unique_ptr<BinBcsr> bin;
};

Formats select_format(const Options& o, const System& s) {
  Formats f;
  if (o.format == "csr") {
    f.op = &s.csr;
  } else {
    if (!s.bcsr)
      throw InputError("format '" + o.format + "' needs 3x3 blocks, and the matrix reads as a scalar system" +
                       std::string(s.csr.rows() % 3 ? " (its size is not divisible by 3)" : "") +
                       ": use --format csr, or --block-size 3 where its unknowns are interleaved 3-component ones");
    if (o.format == "bcsr") {
      f.op = s.bcsr.get();
    } else {
      f.bin = std::make_unique<BinBcsr>(*s.bcsr);
      f.op = f.bin.get();
    }
  }
  return f;
}

/// Every output path checked before any work (a run must not fail at its end for a bad path);
/// under mpirun only rank 0 writes (every rank checked the paths).
void check_outputs(Options& o) {
  if (!o.plot.empty()) {
    std::error_code ec;  // through links: a device, FIFO or folder would be replaced by the PNG's rename
    if (std::filesystem::exists(o.plot, ec) && !std::filesystem::is_regular_file(o.plot, ec))
      throw InputError("--plot: " + o.plot + " is not a regular file (the PNG is written there)");
  }
  if (!o.export_levels.empty()) {
    if (!o.fem) throw InputError("--export-levels needs an FEM scene (--box or --mesh)");
    prepare_output_directory(o.export_levels, "--export-levels");
  }
  if (!o.export_petsc.empty()) {
    if (!o.fem) throw InputError("--export-petsc needs an FEM scene (--box or --mesh)");
    prepare_output_directory(o.export_petsc, "--export-petsc");
  }
  // No output may be an input or another output (the same file through links or paths).
  FilePlan plan;
  plan.input(o.matrix, "--matrix");
  plan.input(o.rhs, "--rhs");
  plan.input(o.solution, "--solution");
  for (const std::string& f : o.levels) plan.input(f, "--levels");
  for (const std::string& f : o.prolongations) plan.input(f, "--prolongations");
  plan.input(o.solver_config, "--solver-config");
  plan.input(o.scene.mesh, "--mesh");
  plan.output(o.history, "--history");
  plan.output(o.solution_out, "--solution-out");
  plan.output(o.plot, "--plot");  // its data and summary are temporary files (plot())
  plan.output(o.json_report, "--json");
  plan.output_folder(o.export_levels, "--export-levels", [](const std::string& name) {
    return name == "b.mtx" || ((name[0] == 'A' || name[0] == 'P') && name.size() > 5 &&
                               name.compare(name.size() - 4, 4, ".mtx") == 0 &&
                               name.find_first_not_of("0123456789", 1) == name.size() - 4);
  });
  plan.output_folder(o.export_petsc, "--export-petsc", [](const std::string& name) {
    return name == "A.petsc" || name == "b.petsc" || name == "coordinates.petsc";
  });
  plan.check();
  if (mpi::launched_rank() != 0) {
    o.plot.clear(), o.json_report.clear(), o.history.clear(), o.export_levels.clear(), o.export_petsc.clear();
    o.solution_out.clear();
  }
}

/// The methods run when --solvers and --solver-config name none: the Krylov methods, the direct
/// solver and BoomerAMG-PCG, and where there are levels the two multigrid methods.
std::vector<std::string> default_solver_names(bool levels, bool blocks = true) {
  std::vector<std::string> names = {"cg", "jacobi-pcg", "block-jacobi-pcg", "mcg", kDefaultDirectMethod, "boomeramg-pcg"};
  if (!blocks) names = {"cg", "jacobi-pcg", kDefaultDirectMethod, "boomeramg-pcg"};  // a scalar system
  if (levels) names.insert(names.end(), {"pmg", "mgpcg"});  // mgpcg flexible where the lowest level iterates
  return names;
}

/// default_solver_names() for --help.
std::string default_solver_help() {
  std::string text;
  for (const std::string& n : default_solver_names(false)) text += (text.empty() ? "" : ", ") + n;
  return text + ", and pmg, mgpcg where there are levels; without the block methods on a scalar system";
}

/// A stopping flag given twice (as a flag and in --set), or to solvers that do not read it, is an
/// error: a conflict is never resolved silently.
void check_stopping_flags(const Options& o, const Config& set,
                          const std::vector<std::pair<std::string, Config>>& configs) {
  for (const auto& [flag, key] : {std::pair<const char*, const char*>{"--tol", "tol"}, {"--max-iter", "max_iterations"},
                                  {"--fixed-iterations", "fixed_iterations"}, {"--check-every", "check_every"}}) {
    if (!o.given.count(flag)) continue;
    if (set.has(key))
      throw InputError(std::string(flag) + " and --set " + key + "=" + set.get_string(key, "") + ": give it once");
    bool read = false;
    for (const auto& nc : configs) read |= reads_stopping_flag(nc.second.get_string("method", kDefaultMethod), key);
    if (!read)
      throw InputError(std::string(flag) + ": no solver of this run reads it (it is the iterative methods' stopping "
                       "rule; a direct solver's check of its residual is --set tol=...)");
  }
}

/// Every solver added to the study (and its options checked) before any runs; a --set key that
/// no solver reads is an error.
void add_solvers(study::Study& st, const Config& set,
                 std::vector<std::pair<std::string, Config>>& configs) {
  std::set<std::string> set_keys, set_used;
  for (const auto& kv : set.items()) set_keys.insert(kv.first);
  for (auto& [name, c] : configs) {
    st.add(name, c, set_keys);  // a block method on a matrix whose size is not divisible by 3: refused
    for (const auto& k : set_keys)
      // "smoother=X" is stored as smoother.method where the solver's options have a smoother tree.
      if (c.was_used(k) || c.was_used(k + ".method")) set_used.insert(k);
  }
  for (const auto& k : set_keys)
    if (!set_used.count(k)) throw InputError("--set: " + k + ": no solver of this run reads it");
}

/// The system, size, format and stopping rule, and the solvers' options where they were given.
void print_header(const Options& o, const System& sys, double load_time, double convert_time,
                  const std::vector<std::pair<std::string, Config>>& configs, double mpi) {
  std::cout << "system:  " << sys.description << "\n"
            << "size:    " << sys.unknowns() << " unknowns, "
            << (sys.nonzeros() >= 0 ? std::to_string(sys.nonzeros()) + " nonzeros" : "finest matrix not assembled (matrix-free solvers only)")
            << (sys.bcsr ? ", " + std::to_string(sys.bcsr->num_blocks()) + " 3x3 blocks" : "") << "\n"
            << "format:  " << o.format << " (load " << fmt("%.3f", load_time) << " s, convert "
            << fmt("%.3f", convert_time) << " s), " << count_of(omp_get_max_threads(), "thread") << "\n";
  if (sys.fem && !sys.fem->setup.stages.empty()) {  // where an FEM scene's load went
    std::cout << "load:   ";
    for (const auto& [name, seconds] : sys.fem->setup.stages) std::cout << " " << name << " " << fmt("%.3f", seconds) << " s;";
    if (sys.fem->finest_assembled) std::cout << " finest assembly " << fmt("%.3f", sys.fem->finest_assembly) << " s;";
    std::cout << "\n";
  }
  std::cout
            << "stop:    "
            << (o.fixed_iterations > 0 ? std::to_string(o.fixed_iterations) + " fixed iterations"
                                       : "relative residual <= " + fmt("%.1e", o.tol))
            << "\n\n";
  const bool given = !o.solver_config.empty() || !o.overrides.empty();
  for (const auto& [name, c] : configs)
    if (given) std::cout << name << ": " << c.to_string() << "\n";
  if (given) std::cout << "\n";
  if (mpi >= 0) std::cout << "MPI (and PETSc) start-up: " << fmt("%.3f", mpi) << " s (charged to no solver)\n\n";
  if (o.warm_up)
    std::cout << "warm-up: each solver runs once untimed before its timed run (the first solver in a "
                 "process otherwise pays the first touch of its memory)\n\n";
}

/// --solution-out: the first solver's answer (expanded to the given numbering for user levels).
void write_solution(const Options& o, const System& sys, const std::vector<study::SolverRun>& runs,
                    const std::vector<Vector>& solutions) {
  if (o.solution_out.empty() || solutions.empty()) return;
  const Vector x = sys.levels ? sys.levels->expand(solutions[0], sys.b_full) : solutions[0];
  if (!x.allFinite()) {  // a failed first solver: its NaN would make a file no reader takes
    std::cout << "solution of " << runs[0].name << " not written to " << o.solution_out << ": it has NaN or Inf entries\n";
    return;
  }
  if (is_petsc_file(o.solution_out)) write_petsc_binary(o.solution_out, x);
  else write_matrix_market_vector(o.solution_out, x);
  std::cout << "solution of " << runs[0].name << " written to " << o.solution_out << "\n";
}

/// An FEM system's reference: this run's own direct solution if it has one, else one direct
/// solve now (after the timed runs: no second factorisation held while the others run).
void reference_solution(System& sys, const std::vector<std::pair<std::string, Config>>& configs,
                        const std::vector<study::SolverRun>& runs, const std::vector<Vector>& solutions) {
  for (size_t k = 0; k < runs.size() && sys.x_true.size() == 0; ++k)
    if (configs[k].second.get_string("method", kDefaultMethod) == kDefaultDirectMethod && runs[k].ok())
      sys.x_true = solutions[k];
  if (sys.x_true.size() == 0) {
    auto direct = make_solver(Config::from_pairs({std::string("method=") + kDefaultDirectMethod}, "the reference solve"));
    try {
      direct->setup(*sys.bcsr);
    } catch (const Error& e) {
      throw InputError(std::string(e.what()) + ": the clamped nodes (" +
                       std::to_string(sys.fem->hierarchy().finest().num_fixed()) +
                       ") do not remove every rigid motion; raise --fix-fraction");
    }
    direct->apply(sys.b, sys.x_true);
  }
  sys.error_reference = "CHOLMOD solution";
}

/// The summary table, failures, settings and breakdowns. Returns whether a solver failed.
bool print_runs(const System& sys, const std::vector<study::SolverRun>& runs) {
  Table table({"solver", "status", "iters", "setup [s]", "solve [s]", "t(1e-3) [s]", "t(1e-6) [s]", "rel. residual",
               "rel. error"});
  bool failed = false;
  std::string repeated;
  for (const auto& r : runs) {
    failed |= !r.ok();
    if (r.repetitions > 1)
      repeated += (repeated.empty() ? "" : ", ") + r.name +
                  (r.repetitions != study::Study::kShortRepetitions ? " of " + std::to_string(r.repetitions) : "");
    table.add({r.name, r.status, std::to_string(r.iterations), fmt("%.4f", r.setup_s), fmt("%.4f", r.solve_s),
               fmt("%.4f", r.time_to(1e-3)), fmt("%.4f", r.time_to(1e-6)), fmt("%.2e", r.rel_residual),
               fmt("%.2e", r.rel_error)});
  }
  table.print(std::cout);
  if (!repeated.empty())
    std::cout << "times: the run of median time of " << study::Study::kShortRepetitions << " for set-ups and solves under "
              << study::Study::kShortRun << " s (" << repeated << "): a millisecond's run is otherwise at the mercy of the scheduler\n";
  for (const auto& r : runs)
    if (!r.ok()) std::cout << "\n" << r.name << " failed: " << r.message << "\n";
  for (const std::string study::SolverRun::*part :
       {&study::SolverRun::settings, &study::SolverRun::setup_breakdown, &study::SolverRun::breakdown})
    for (const auto& r : runs)
      if (!(r.*part).empty()) std::cout << "\n" << r.name << ": " << r.*part << "\n";
  if (sys.x_true.size()) std::cout << "\nrel. error: against the " << sys.error_reference << "\n";
  return failed;
}

/// What a report's JSON holds besides the runs.
struct RunFigures {
  double load_s = 0.0, convert_s = 0.0, mpi_s = -1.0, lower_levels_s = -1.0, matrix_free_s = -1.0;
  std::string history;
};

/// --json: every figure of the table, with units in the key names; NaN and "not measured" are null.
void write_report(const Options& o, const System& sys, const std::vector<study::SolverRun>& runs, const RunFigures& f) {
  auto seconds_or_null = [](double v) { return v >= 0 ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json report = {
      {"command", "pmg compare"},
      {"system", {{"description", sys.description},
                  {"unknowns", sys.unknowns()},
                  {"nonzeros", sys.nonzeros() >= 0 ? nlohmann::json(sys.nonzeros()) : nlohmann::json(nullptr)},
                  {"blocks", sys.blocks() >= 0 ? nlohmann::json(sys.blocks()) : nlohmann::json(nullptr)},
                  {"finest_assembled", !sys.fem || sys.fem->finest_assembled}}},
      {"format", o.format},
      {"load_s", f.load_s},
      {"load_stages", [&] {  // an FEM scene's load by stage, in order (sim::SceneSetup::stages)
         nlohmann::json j = nlohmann::json::array();
         if (sys.fem)
           for (const auto& [name, seconds] : sys.fem->setup.stages) j.push_back({{"stage", name}, {"seconds", seconds}});
         return j;
       }()},
      {"convert_s", f.convert_s},
      {"threads", omp_get_max_threads()},
      // Whether malloc asked for transparent huge pages (pmg's start-up; docs/scaling.md): the
      // set-up times depend on it.
      {"malloc_huge_pages", [] {
         const char* t = std::getenv("GLIBC_TUNABLES");
         return t && std::string(t).find("glibc.malloc.hugetlb=1") != std::string::npos;
       }()},
      {"stop", o.fixed_iterations > 0 ? nlohmann::json({{"fixed_iterations", o.fixed_iterations}})
                                      : nlohmann::json({{"rel_tol", o.tol}})},
      {"warm_up", o.warm_up},
      {"mpi_startup_s", seconds_or_null(f.mpi_s)},
      {"lower_levels_s", seconds_or_null(f.lower_levels_s)},
      {"matrix_free_s", seconds_or_null(f.matrix_free_s)},
      {"user_levels_s", seconds_or_null(sys.user_levels_s)},
      {"error_reference", sys.x_true.size() ? nlohmann::json(sys.error_reference) : nlohmann::json(nullptr)},
      {"history", f.history},
      {"solvers", nlohmann::json::parse(study::runs_json(runs))}};
  write_file_atomically(o.json_report, report.dump(2) + "\n");
  std::cout << "report:  " << o.json_report << "\n";
}

/// --formulation mixed takes an FEM scene and writes only the table and --json: the options it
/// cannot honour are refused by name.
void check_mixed_options(const Options& o) {
  if (!o.fem || !o.matrix.empty() || !o.levels.empty())
    throw InputError("--formulation mixed needs an FEM scene (--box or --mesh), not a matrix or user levels");
  const std::pair<bool, const char*> refused[] = {
      {o.distributed_mesh, "--distributed-mesh"}, {!o.history.empty(), "--history"}, {!o.plot.empty(), "--plot"},
      {!o.solution_out.empty(), "--solution-out"}, {!o.export_levels.empty(), "--export-levels"},
      {!o.export_petsc.empty(), "--export-petsc"}, {o.warm_up, "--warm-up"}, {!o.save_mesh.empty(), "--save-mesh"}};
  for (const auto& [given, name] : refused)
    if (given) throw InputError(std::string("--formulation mixed does not take ") + name);
}

void run(const Options& given) {
  Options o = given;
  if (o.formulation == "mixed") check_mixed_options(o);
  if (o.distributed_mesh) {
    FilePlan plan;  // no output may be the mesh read or the other output
    plan.input(o.scene.mesh, "--mesh");
    plan.output(o.json_report, "--json");
    plan.output(o.save_mesh, "--save-mesh");
    plan.output(o.history, "--history");
    plan.check();
    const Config set = Config::from_pairs(o.overrides, "--set");
    run_distributed_mesh(o.scene, solver_configs(o, {"petsc-mgpcg"}, set).front().second,
                         {o.json_report, o.save_mesh, o.history});
    return;
  }
  if (o.formulation == "mixed") {
    FilePlan plan;
    plan.input(o.scene.mesh, "--mesh");
    plan.output(o.json_report, "--json");
    plan.check();
    const Config set = Config::from_pairs(o.overrides, "--set");
    std::vector<std::string> names = o.solvers;
    if (names.empty()) {
      names = {"mixed-gmres", "mixed-minres"};
      const auto all = registered_solvers();
      for (const char* peer : {"fieldsplit-gmres", "mumps"})  // PETSc's iterative and direct peers
        if (std::any_of(all.begin(), all.end(), [&](const SolverInfo& i) { return i.name == peer; }))
          names.push_back(peer);
    }
    run_mixed(o.scene, solver_configs(o, names, set), o.json_report);
    return;
  }
  check_outputs(o);
  auto t0 = Clock::now();
  System sys = load_system(o);
  if (!o.matrix.empty() && !sys.bcsr && !o.given.count("--format")) o.format = "csr";
  if (!o.export_levels.empty()) export_levels(*sys.fem, o.export_levels);
  if (!o.export_petsc.empty()) export_petsc(*sys.fem, o.export_petsc);
  RunFigures figures;
  figures.load_s = seconds_since(t0);

  study::StudySystem ss;
  ss.repeat_short_runs = mpi::launched_ranks() <= 1;  // every rank runs each solver alike
  ss.description = sys.description;
  ss.b = sys.b;
  ss.levels = sys.levels ? static_cast<const mg::LevelProvider*>(sys.levels.get())
              : sys.fem ? &sys.fem->hierarchy() : nullptr;
  std::vector<double> coordinates;  // FEM: the free nodes' rest positions (rigid-body modes)
  if (sys.fem) {
    coordinates = sys.fem->free_coordinates();
    ss.coordinates = &coordinates;
    ss.hierarchy = &sys.fem->hierarchy();
    ss.weights = sys.fem->weights();
  }
  // Solvers read the entries of BCSR (CSR when the size is not a multiple of 3); an FEM system's
  // finest matrix is assembled below, where a solver reads it.
  ss.matrix = sys.bcsr ? static_cast<const LinearOperator*>(sys.bcsr.get()) : sys.fem ? nullptr : &sys.csr;
  const Config set = Config::from_pairs(o.overrides, "--set");  // read once, for every solver
  std::vector<std::string> names = o.solvers;
  if (names.empty()) names = default_solver_names(ss.levels && ss.levels->num_levels() > 1, sys.bcsr || sys.fem);
  std::vector<std::pair<std::string, Config>> configs = solver_configs(o, names, set);
  check_stopping_flags(o, set, configs);
  study::Study st(ss);
  add_solvers(st, set, configs);
  figures.mpi_s = st.library_startup_s();
  // FEM: the finest matrix, where a solver multiplies with it or reads its entries (matrix-free
  // solvers do neither); its assembly belongs to the load time.
  if (sys.fem && !sys.bcsr && st.reads_finest_matrix()) {
    sys.fem->assemble_finest();
    figures.load_s += sys.fem->finest_assembly;
    sys.bcsr = borrow(sys.fem->matrix());
    ss.matrix = sys.bcsr.get();
  }
  t0 = Clock::now();
  const Formats formats = sys.bcsr || !sys.fem ? select_format(o, sys) : Formats{};
  figures.convert_s = seconds_since(t0);
  // The Krylov methods multiply in the requested format (matrix-free ones: with the finest operator).
  ss.product = formats.op;
  ss.reference = sys.x_true;
  print_header(o, sys, figures.load_s, figures.convert_s, configs, figures.mpi_s);
  std::vector<Vector> solutions;
  std::vector<study::SolverRun> runs = st.run(o.warm_up, &solutions);
  figures.lower_levels_s = st.lower_levels_s();
  figures.matrix_free_s = st.matrix_free_s();
  write_solution(o, sys, runs, solutions);
  if (sys.reference_pending) {
    reference_solution(sys, configs, runs, solutions);
    study::measure_errors(runs, solutions, sys.x_true);
  }
  const bool failed = print_runs(sys, runs);
  figures.history = o.history;
  if (!o.history.empty()) {
    study::write_history(o.history, runs);
    std::cout << "history: " << o.history << "\n";
  }
  if (!o.plot.empty()) plot(runs, o.history, o.plot, sys.description);
  if (!o.json_report.empty()) write_report(o, sys, runs, figures);
  if (failed) throw Exit{kSolveFailed};
}

}  // namespace

/// The options that name the system: a Matrix Market file (with its right-hand side, known
/// solution and block size) or the built-in lattice.
void add_system_options(CLI::App* sub, const std::shared_ptr<Options>& opts) {
  sub->add_option("-m,--matrix", opts->matrix, "Matrix Market file (symmetric positive definite)")
      ->check(CLI::ExistingFile);
  sub->add_option("-b,--rhs", opts->rhs, "right-hand side (Matrix Market array or n x 1)")
      ->check(CLI::ExistingFile);
  sub->add_option("-x,--solution", opts->solution, "known solution, for the error column")
      ->check(CLI::ExistingFile)
      ->needs("--matrix");
  sub->add_option("--block-size", opts->block_size,
                  "--matrix: unknowns per node; auto: 3 (3x3 blocks, interleaved) where the three rows of each "
                  "node couple to the same nodes, else 1 (a scalar system: the scalar methods run)")
      ->check(CLI::IsMember({"auto", "1", "3"}))
      ->needs("--matrix")
      ->capture_default_str();
  sub->add_option("-n,--grid", opts->grid, "built-in lattice: nodes per edge (3 unknowns each)")
      ->check(CLI::Range(2, 400))
      ->capture_default_str();
}

void register_compare(CLI::App& app) {
  auto opts = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "compare", "Run several solvers on one SPD system and report residual against time (methods and their "
                 "keys: pmg solvers)");
  add_system_options(sub, opts);
  sub->add_option("-s,--solvers", opts->solvers,
                  "comma-separated methods: " + method_list() + " (default: " + default_solver_help() + ")")
      ->delimiter(',');
  sub->add_option("--set", opts->overrides,
                  "solver option key=value for every solver of the run (repeatable; e.g. smoother=chebyshev "
                  "smoother.degree=4 cycle=W lowest_level=boomeramg; keys and defaults: pmg solvers METHOD). "
                  "PMG and MGPCG on FEM levels default to the matrix-free route (operator=auto: optimised "
                  "fourth-kind Chebyshev of degree 3, one cycle per MGPCG application, CHOLMOD on the linear "
                  "level)");
  sub->add_option("--solver-config", opts->solver_config,
                  "JSON file of named solver configurations run side by side "
                  "({\"name\": {\"method\": \"mgpcg\", ...}, ...}); replaces --solvers")
      ->check(CLI::ExistingFile)
      ->excludes("--solvers");
  sub->add_option("-f,--format", opts->format,
                  "matrix format for the Krylov solvers (default: bcsr; csr for a scalar --matrix)")
      ->check(CLI::IsMember({"csr", "bcsr", "bin-bcsr"}))
      ->capture_default_str();
  sub->add_option("-t,--tol", opts->tol, "relative residual tolerance")
      ->check(Tolerance())
      ->capture_default_str();
  sub->add_option("--max-iter", opts->max_iterations, "iteration limit")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--fixed-iterations", opts->fixed_iterations,
                  "run exactly this many iterations (no tolerance)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--check-every", opts->check_every,
                  "merged CG: test convergence every k iterations")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--history", opts->history,
                  "write the per-iteration history as CSV (solver,iteration,seconds,rel_residual)");
  // -o names an output folder (pmg simulate, pmg render); here it is refused with --history named,
  // not taken as the history file (hidden from the help).
  auto dash_o = std::make_shared<std::string>();
  sub->add_option("-o", *dash_o)->expected(0, 1)->group("");
  sub->add_option("--json", opts->json_report,
                  "also write every figure of the table to this JSON file (units in the key names)");
  add_formulation_option(sub, opts->formulation);
  sub->add_flag("--warm-up", opts->warm_up,
                "run each solver once untimed first: warm timings, independent of the solvers' order");
  add_threads_option(sub);
  sub->add_option("--plot", opts->plot,
                  "draw residual against time and iterations, and error against time, to this PNG (its data: "
                  "temporary files, or the --history file)");
  sub->add_option("--levels", opts->levels,
                  "multigrid level matrices, coarsest first (Matrix Market or PETSc binary .petsc, 3 unknowns "
                  "per node; identity rows of clamped nodes are removed)")
      ->delimiter(',')
      ->check(CLI::ExistingFile)
      ->excludes("--matrix");
  sub->add_option("--prolongations", opts->prolongations,
                  "prolongations between those levels, coarsest first (nodes x nodes, or dofs x dofs of the form P ⊗ I3)")
      ->delimiter(',')
      ->check(CLI::ExistingFile)
      ->needs("--levels");
  sub->add_option("--layout", opts->layout,
                  "--levels: dof order of the level matrices (interleaved x0 y0 z0 x1 ..., or component x0 x1 ... y0 ...)")
      ->check(CLI::IsMember({"interleaved", "component"}))
      ->capture_default_str()
      ->needs("--levels");
  sub->add_flag("--galerkin-from-finest", opts->galerkin_from_finest,
                "--levels gives the finest matrix only: the lower levels are Galerkin products")
      ->needs("--levels");
  sub->add_option("--solution-out", opts->solution_out,
                  "write the first solver's solution (Matrix Market, or PETSc binary for .petsc): the "
                  "full vector for --matrix/--levels, the free dofs for FEM scenes");
  sub->add_option("--export-levels", opts->export_levels,
                  "FEM scenes: write the level matrices, prolongations and b to this folder");
  sub->add_option("--export-petsc", opts->export_petsc,
                  "FEM scenes: write the system in PETSc's binary format to this folder (A.petsc, b.petsc, "
                  "coordinates.petsc: what PETSc's MatLoad/VecLoad and bench/petsc/petsc_reference read)");
  add_scene_options(sub, opts->scene);
  sub->add_flag("!--no-reference", opts->reference, "FEM scenes: skip the direct reference solve");
  add_distributed_mesh_options(sub, opts->distributed_mesh, opts->save_mesh);
  // Multigrid flags of earlier versions: each duplicated a --set key, so they are retired with a
  // message naming it (hidden from the help).
  static const std::pair<const char*, const char*> retired[] = {
      {"--coarse-operator", "coarse_operator"}, {"--restriction", "restriction"}, {"--cycle", "cycle"},
      {"--smoother", "smoother"}, {"--sweeps", "smoother.sweeps"}, {"--lowest-level", "lowest_level"},
      {"--lowest-level-cycles", "lowest_level.cycles"}, {"--lowest-level-tol", "lowest_level.tol"},
      {"--mgpcg-cycles", "cycles"}};
  auto retired_values = std::make_shared<std::vector<std::string>>(std::size(retired));
  for (size_t k = 0; k < std::size(retired); ++k) sub->add_option(retired[k].first, (*retired_values)[k])->group("");
  sub->callback([opts, sub, retired_values, dash_o] {
    // Ranks given different commands stop here, together, before any rank refuses its own.
    std::vector<std::string> inputs = {opts->matrix, opts->rhs, opts->solution, opts->solver_config, opts->scene.mesh};
    inputs.insert(inputs.end(), opts->levels.begin(), opts->levels.end());
    inputs.insert(inputs.end(), opts->prolongations.begin(), opts->prolongations.end());
    agree_across_ranks(*sub, inputs);
    if (sub->count("-o"))
      throw InputError("-o is not a pmg compare option (-o names an output folder in pmg simulate and pmg render): "
                       "write the residual history CSV with --history FILE");
    for (const char* flag : {"--tol", "--max-iter", "--fixed-iterations", "--check-every", "--format"})
      if (sub->count(flag)) opts->given.insert(flag);
    opts->fem = sub->count("--mesh") || sub->count("--box") || sub->count("--degree") || sub->count("--refine") ||
                sub->count("--load") || sub->count("--dt");
    for (size_t k = 0; k < std::size(retired); ++k)
      if (sub->count(retired[k].first))
        throw InputError(std::string(retired[k].first) + " was retired: use --set " + retired[k].second + "=" +
                         (*retired_values)[k] +
                         (std::string(retired[k].first) == "--mgpcg-cycles"
                              ? " with --solvers mgpcg (--set reaches every solver of the run)"
                              : "") +
                         " (keys and defaults: pmg solvers)");
    if (opts->fem && (!opts->matrix.empty() || !opts->levels.empty()))
      throw InputError("give either an FEM scene or --matrix/--levels, not both");
    check_distributed_mesh(*sub, opts->distributed_mesh, opts->solvers, opts->save_mesh);
    if (opts->distributed_mesh) opts->fem = true, opts->reference = false;
    run(*opts);
  });
}

}  // namespace pmg::tools
