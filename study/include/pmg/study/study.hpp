// pmg/study/study.hpp — solver studies: several solvers of the factory on one system, each set up
// and solved from zero under a clock, with its residual history, its error against a reference
// and its timing breakdowns. `pmg compare`, Python's pmgkit.study() and the benchmark scripts run
// their comparisons through this one layer.
//
//   pmg::study::StudySystem sys;            // the matrix, b, a reference solution, levels ...
//   sys.matrix = &A;  sys.b = b;  sys.reference = x_ref;
//   pmg::study::Study study(sys);
//   study.add("cg", pmg::Config::from_pairs({"method=cg", "tol=1e-8"}, "example"));
//   study.add("mgpcg", pmg::Config::from_pairs({"method=mgpcg"}, "example"));   // with sys.levels
//   for (const pmg::study::SolverRun& r : study.run()) std::cout << r.name << " " << r.time_to(1e-6);
//
// An FEM system (sys.hierarchy) binds each solver to the hierarchy (fem::BoundSystem): the levels
// a solver reads are prepared once per kind of need, outside its clock, and charged to its set-up.
#pragma once

#include "pmg/fem/bound_system.hpp"
#include "pmg/sparse/config.hpp"
#include "pmg/sparse/defaults.hpp"
#include "pmg/sparse/level_provider.hpp"
#include "pmg/sparse/monitor.hpp"
#include "pmg/sparse/solver.hpp"

#include <limits>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace pmg::study {

/// One solver's run in a study.
struct SolverRun {
  std::string name;             ///< the name the study gave it
  std::string config;           ///< its options as run (Config::to_string)
  std::string status = "ok";    ///< to_string(SolveStatus), or "set-up failed"
  std::string message;          ///< why it failed (empty: it did not)
  std::string settings;         ///< what its set-up chose (Solver::describe)
  std::string breakdown;        ///< where the solve's time went (Solver::timings)
  std::string setup_breakdown;  ///< where the set-up's time went, the levels' preparation first
  int iterations = 0;           ///< iterations (or cycles) of the solve
  double setup_s = 0.0;         ///< set-up seconds, the levels it needed prepared included
  double solve_s = 0.0;         ///< solve seconds
  /// Runs the times are the median of: a run shorter than Study::kShortRun seconds (set-up and
  /// solve) is repeated, so that a scheduler's stall of a few milliseconds (a thread of an OpenMP
  /// team descheduled at a barrier on a small VM) does not make its figure.
  int repetitions = 1;
  /// True ‖b − Ax‖ / ‖b − Ax₀‖ at the end (the recursive one for fixed-iteration runs).
  double rel_residual = std::numeric_limits<double>::quiet_NaN();
  /// ‖x − x_ref‖ / ‖x_ref‖ against StudySystem::reference (NaN: no reference, or a failed run).
  double rel_error = std::numeric_limits<double>::quiet_NaN();
  /// bᵀx of the answer (NaN: a failed run): xᵀAx at the solution, independent of the numbering
  /// of the unknowns; for an FEM scene the compliance (external work, J).
  double b_dot_x = std::numeric_limits<double>::quiet_NaN();
  std::vector<IterationRecord> history;  ///< relative residual and seconds per iteration

  /// True when the run neither failed to set up nor threw.
  bool ok() const { return message.empty(); }
  /// Set-up plus the time at which the history first reached `rel` (NaN: never).
  double time_to(double rel) const;
};

/// The system a study solves (see the file comment). What it points to must outlive the study.
struct StudySystem {
  std::string description;  ///< one line, for reports
  /// The matrix whose entries solvers read (CSR, or BCSR where the size allows); an FEM system's
  /// finest matrix where it was assembled (nullptr: not assembled, matrix-free solvers only).
  const LinearOperator* matrix = nullptr;
  /// The format Krylov methods multiply in (BIN-BCSR, CSR ...; nullptr: `matrix` itself).
  const LinearOperator* product = nullptr;
  Vector b;          ///< the right-hand side
  Vector reference;  ///< the solution errors are measured against (empty: none known)
  /// Multigrid levels (user levels, or an FEM system's degree hierarchy); nullptr: none.
  const LevelProvider* levels = nullptr;
  /// An FEM system's degree hierarchy: solvers are bound to it (fem::BoundSystem); nullptr: none.
  fem::DegreeHierarchy* hierarchy = nullptr;
  fem::SystemWeights weights;  ///< the FEM system's weights (mass M + stiffness K)
  /// x, y, z per node of the system (AMG's rigid-body modes); nullptr: unknown.
  const std::vector<double>* coordinates = nullptr;
  /// Repeat short runs (Study::kShortRun) and report the median. Set false where processes run
  /// the study side by side under an MPI launcher: hypre's BoomerAMG, for one, solves across the
  /// world's ranks, and each rank's own clock would choose its own number of runs.
  bool repeat_short_runs = true;
};

/// Several solvers on one system (see the file comment).
class Study {
 public:
  /// On `system`, which must outlive the study.
  explicit Study(StudySystem& system);
  ~Study();
  Study(const Study&) = delete;
  Study& operator=(const Study&) = delete;

  /// Builds the solver `config` names (method `fallback_method` where it names none), before any
  /// runs, as make_solver() builds (adapt_to_input: layout, blocks): InputError for a method of 3x3
  /// blocks on a matrix that does not read as blocks (check_block_reading; StudySystem::matrix set
  /// before add()), or naming a key no part of it read, except those in `may_be_unused` (keys given
  /// to every solver of a study). Starts MPI and PETSc where the method needs them, outside every
  /// clock. `config` is kept (Config::was_used tells which keys it read).
  void add(const std::string& name, const Config& config, const std::set<std::string>& may_be_unused = {},
           const std::string& fallback_method = kDefaultMethod);
  /// The number of solvers added.
  int size() const { return static_cast<int>(entries_.size()); }
  /// Whether some solver reads the finest matrix's entries or multiplies with it (on an FEM
  /// system StudySystem::matrix must then be assembled and set before run()).
  bool reads_finest_matrix() const;
  /// Seconds of MPI and PETSc start-up paid by add() (-1: none needed).
  double library_startup_s() const { return startup_s_; }

  /// A run (set-up and solve) shorter than this many seconds is repeated, up to kShortRepetitions
  /// runs in all, and reported by the run of median time (SolverRun::repetitions).
  static constexpr double kShortRun = 0.1;
  /// The runs of a short solver (odd: the median is one of them).
  static constexpr int kShortRepetitions = 5;

  /// Runs every solver in turn from x = 0: set-up timed (the levels it reads prepared first, once
  /// per kind of need, and charged to it), solve timed and monitored, error against the
  /// reference; a run shorter than kShortRun is repeated and reported by its median run. With
  /// `warm_up` each runs once untimed first (the first touch of its memory). A
  /// solver is released after its run, so a study runs once (InputError after). `solutions` (may
  /// be nullptr) receives each final iterate.
  std::vector<SolverRun> run(bool warm_up = false, std::vector<Vector>* solutions = nullptr);
  /// Seconds the last run() spent assembling lower levels for solvers that read them (-1: none).
  double lower_levels_s() const { return lower_levels_s_; }
  /// Seconds the last run() spent building matrix-free levels (-1: none).
  double matrix_free_s() const { return matrix_free_s_; }

 private:
  struct Entry {
    std::string name;
    Config config;
    std::unique_ptr<Solver> solver;
    std::string method;  ///< the method it runs
  };
  struct Prepared {
    double seconds = 0.0;
    std::vector<std::pair<std::string, double>> parts;
  };
  SolverRun run_one(Entry& e, Vector& x);

  StudySystem& system_;
  std::vector<Entry> entries_;
  std::map<std::string, Prepared> prepared_;  // by fem::BoundSystem::preparation_key()
  double startup_s_ = -1.0, lower_levels_s_ = -1.0, matrix_free_s_ = -1.0;
};

/// Sets `solver` up on A (timed) and solves A x = b from x (timed, monitored); `prepared_s` and
/// `prepared_parts` are the levels' preparation, charged to the set-up. A set-up that throws is
/// reported as "set-up failed" with x set to NaN; a solve that throws SolveError as its status.
SolverRun run_solver(const std::string& name, Solver& solver, const LinearOperator& A, const Vector& b, Vector& x,
                     double prepared_s = 0.0, const std::vector<std::pair<std::string, double>>& prepared_parts = {});

/// rel_error of each run that succeeded, against `reference` (solutions[k] is run k's answer).
void measure_errors(std::vector<SolverRun>& runs, const std::vector<Vector>& solutions, const Vector& reference);

/// The histories as CSV: solver,iteration,seconds,rel_residual (seconds include the set-up),
/// written atomically.
void write_history(const std::string& path, const std::vector<SolverRun>& runs);
/// The runs as a JSON array (text): every figure of SolverRun with units in the key names, NaN
/// as null.
std::string runs_json(const std::vector<SolverRun>& runs);

}  // namespace pmg::study
