#include "pmg/study/study.hpp"

#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/timer.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pmg::study {

namespace {
const double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

double SolverRun::time_to(double rel) const {
  for (const auto& h : history)
    if (h.rel_residual <= rel) return setup_s + h.seconds;
  return kNaN;
}

SolverRun run_solver(const std::string& name, Solver& solver, const LinearOperator& A, const Vector& b, Vector& x,
                     double prepared_s, const std::vector<std::pair<std::string, double>>& prepared_parts) {
  SolverRun out;
  out.name = name;
  auto t0 = Clock::now();
  try {
    solver.setup(A);
  } catch (const Error& e) {  // e.g. a lowest level that is not positive definite
    out.setup_s = seconds_since(t0) + prepared_s;
    out.status = "set-up failed";
    out.message = e.what();
    x.setConstant(kNaN);
    return out;
  }
  out.setup_s = seconds_since(t0) + prepared_s;
  // The set-up by stage: the levels' preparation (outside the solver), then the solver's own.
  TimingBreakdown stages = solver.setup_timings();
  if (!stages.empty() || !prepared_parts.empty()) {
    stages.count = 1, stages.unit = "set-up";
    stages.parts.insert(stages.parts.begin(), prepared_parts.begin(), prepared_parts.end());
    double staged = 0.0;
    for (const auto& p : stages.parts) staged += p.second;
    stages.parts.emplace_back("other", std::max(0.0, out.setup_s - staged));
    out.setup_breakdown = stages.to_string();
  }
  solver.reset_timings();
  SolveMonitor monitor;
  t0 = Clock::now();
  SolveResult r;
  try {
    r = solver.solve(b, x, &monitor);
  } catch (const SolveError& e) {
    r = e.result;
    out.message = e.what();
  }
  out.solve_s = seconds_since(t0);
  out.settings = solver.describe();  // after the solve: the GPU solvers report its copies' times
  out.history = monitor.history();
  out.iterations = r.iterations;
  out.rel_residual = std::isnan(r.true_rel_residual) ? r.rel_residual : r.true_rel_residual;
  out.status = to_string(r.status);
  out.breakdown = solver.timings().to_string();
  return out;
}

Study::Study(StudySystem& system) : system_(system) {}
Study::~Study() = default;

void Study::add(const std::string& name, const Config& config, const std::set<std::string>& may_be_unused,
                const std::string& fallback_method) {
  const std::string method = config.get_string("method", fallback_method);
  // A block method on a matrix that does not read as blocks: refused before anything runs (the
  // set-up would refuse it too, BlockInput), unless its layout is declared.
  if (method_needs_blocks(method) && system_.matrix && !system_.levels && !config.has("layout"))
    if (const Csr* c = system_.matrix->csr_matrix()) check_block_reading(*c, name);
  SolverContext ctx;
  ctx.levels = system_.levels;
  ctx.coordinates = system_.coordinates;
  // As make_solver() builds: the method, then what the matrix it is given needs (layout, blocks).
  Entry e{name, config, adapt_to_input(build_solver(config, ctx, fallback_method), config, ctx, fallback_method), method};
  config.check_all_used(may_be_unused);
  // MPI's and PETSc's start-up is paid once per process: started here, before the clocks, so that
  // it is charged to no solver.
  startup_s_ = std::max(startup_s_, start_libraries(config));
  entries_.push_back(std::move(e));
}

bool Study::reads_finest_matrix() const {
  if (!system_.hierarchy || system_.hierarchy->num_levels() < 2) return true;
  for (const Entry& e : entries_)
    if (e.solver && !system_.hierarchy->bind(*e.solver).matrix_free()) return true;
  return false;
}

SolverRun Study::run_one(Entry& e, Vector& x) {
  Solver& solver = *e.solver;
  static const Csr no_matrix;  // an FEM system whose finest matrix no solver reads
  const LinearOperator& entries = system_.matrix ? *system_.matrix : no_matrix;
  if (system_.product) solver.multiply_with(system_.product);
  if (!system_.hierarchy) return run_solver(e.name, solver, entries, system_.b, x);
  // FEM: what the solver reads beyond the finest matrix (lower levels, matrix-free operators),
  // prepared once per kind of need outside the solvers' clocks and charged to each that needs it.
  fem::BoundSystem bound = system_.hierarchy->bind(solver);
  Prepared extra;
  if (const std::string key = bound.preparation_key(); !key.empty()) {
    if (!prepared_.count(key)) {
      // The finest matrix comes assembled with the system; a matrix-free binding prepares its
      // finest operator here.
      const auto t0 = Clock::now();
      bound.prepare(nullptr, system_.weights, /*finest=*/bound.matrix_free());
      prepared_[key] = {seconds_since(t0), bound.prepare_seconds()};
    }
    extra = prepared_[key];
    (bound.matrix_free() ? matrix_free_s_ : lower_levels_s_) = extra.seconds;
  }
  // A matrix-free solver multiplies with the finest operator too.
  const LinearOperator& A = bound.matrix_free() ? bound.system() : entries;
  if (bound.matrix_free()) solver.multiply_with(&A);
  return run_solver(e.name, solver, A, system_.b, x, extra.seconds, extra.parts);
}

std::vector<SolverRun> Study::run(bool warm_up, std::vector<Vector>* solutions) {
  for (const Entry& e : entries_)
    if (!e.solver) throw InputError("study: the solver " + e.name + " has run already (a study runs once)");
  if (reads_finest_matrix() && !system_.matrix)
    throw InputError("study: a solver reads the finest matrix, which the system does not hold (assemble it)");
  std::vector<SolverRun> runs;
  std::vector<Vector> answers(entries_.size());
  prepared_.clear();
  lower_levels_s_ = matrix_free_s_ = -1.0;
  for (size_t k = 0; k < entries_.size(); ++k) {
    Entry& e = entries_[k];
    if (warm_up) {
      Vector w = Vector::Zero(system_.b.size());
      run_one(e, w);
    }
    answers[k] = Vector::Zero(system_.b.size());
    SolverRun first = run_one(e, answers[k]);
    // Not across MPI ranks: the ranks' clocks differ, and every rank must run alike.
    const bool across_ranks = solver_info(e.method).across_ranks || !system_.repeat_short_runs;
    if (first.ok() && !across_ranks && first.setup_s + first.solve_s < kShortRun) {
      // Short runs again, each from zero, reported by the run of median time.
      std::vector<std::pair<SolverRun, Vector>> more;
      more.emplace_back(std::move(first), answers[k]);
      for (int r = 1; r < kShortRepetitions; ++r) {
        Vector x = Vector::Zero(system_.b.size());
        SolverRun again = run_one(e, x);
        if (!again.ok()) break;
        more.emplace_back(std::move(again), std::move(x));
      }
      std::sort(more.begin(), more.end(), [](const auto& a, const auto& b) {
        return a.first.setup_s + a.first.solve_s < b.first.setup_s + b.first.solve_s;
      });
      auto& median = more[more.size() / 2];
      median.first.repetitions = static_cast<int>(more.size());
      first = std::move(median.first);
      answers[k] = std::move(median.second);
    }
    runs.push_back(std::move(first));
    runs.back().config = e.config.to_string();
    e.solver.reset();  // its factors and hierarchies are not held while the next one runs
  }
  for (size_t k = 0; k < runs.size() && k < answers.size(); ++k)
    if (runs[k].ok() && answers[k].size() == system_.b.size()) runs[k].b_dot_x = system_.b.dot(answers[k]);
  if (system_.reference.size()) measure_errors(runs, answers, system_.reference);
  if (solutions) *solutions = std::move(answers);
  return runs;
}

void measure_errors(std::vector<SolverRun>& runs, const std::vector<Vector>& solutions, const Vector& reference) {
  for (size_t k = 0; k < runs.size() && k < solutions.size(); ++k)
    if (runs[k].ok() && solutions[k].size() == reference.size())
      runs[k].rel_error = (solutions[k] - reference).norm() / reference.norm();
}

void write_history(const std::string& path, const std::vector<SolverRun>& runs) {
  std::ostringstream csv;
  csv.precision(10);
  csv << "solver,iteration,seconds,rel_residual\n";
  for (const auto& r : runs)
    for (const auto& h : r.history) csv << r.name << "," << h.iteration << "," << r.setup_s + h.seconds << "," << h.rel_residual << "\n";
  write_file_atomically(path, csv.str());
}

std::string runs_json(const std::vector<SolverRun>& runs) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json out = nlohmann::json::array();
  for (const SolverRun& r : runs)
    out.push_back({{"name", r.name},
                   {"config", r.config},
                   {"status", r.status},
                   {"message", r.message},
                   {"iterations", r.iterations},
                   {"setup_s", r.setup_s},
                   {"solve_s", r.solve_s},
                   {"repetitions", r.repetitions},
                   {"time_to_1e-3_s", num(r.time_to(1e-3))},
                   {"time_to_1e-6_s", num(r.time_to(1e-6))},
                   {"rel_residual", num(r.rel_residual)},
                   {"rel_error", num(r.rel_error)},
                   {"b_dot_x", num(r.b_dot_x)},
                   {"settings", r.settings},
                   {"breakdown", r.breakdown},
                   {"setup_breakdown", r.setup_breakdown}});
  return out.dump();
}

}  // namespace pmg::study
