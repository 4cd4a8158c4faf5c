// pmg/sparse/monitor.hpp — what an iterative solve reports: a status, and per iteration the
// relative residual and the wall time since the solve started. Every residual-against-time table
// and plot in pmgkit comes from a SolveMonitor's history.
#pragma once

#include "pmg/sparse/types.hpp"

#include <chrono>
#include <functional>
#include <string>
#include <vector>

namespace pmg {

/// One entry of a SolveMonitor's history.
struct IterationRecord {
  int iteration;        ///< 0 is the initial residual
  double seconds;       ///< wall time since start()
  double rel_residual;  ///< ||r_i|| / ||r_0||
};

/// Records the relative residual and the elapsed time of each iteration of a solve (see the file
/// comment); the solver calls start() and record(), the caller reads history().
class SolveMonitor {
 public:
  /// Resets the history and starts the clock.
  void start();
  /// Appends a record with the time since start() and calls on_record if it is set.
  void record(int iteration, double rel_residual);
  /// Wall time since start() (or since construction), seconds.
  double elapsed() const;
  /// The records since the last start(), in order.
  const std::vector<IterationRecord>& history() const { return history_; }
  /// Optional observer, called after every record (progress output, custom stopping logic).
  std::function<void(const IterationRecord&)> on_record;

 private:
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  std::vector<IterationRecord> history_;
};

/// How a solve ended: converged and completed are success (SolveResult::ok()), the rest failures.
enum class SolveStatus {
  converged,        ///< relative residual (recursive and true) below the tolerance
  completed,        ///< fixed-iteration mode ran its iterations, or a preconditioner's one correction
  iteration_limit,  ///< tolerance not reached within max_iterations
  breakdown,        ///< a division by a non-positive curvature: operator or preconditioner not SPD
  diverged,         ///< relative residual above the divergence limit
  non_finite,       ///< NaN or Inf appeared
  stagnated,        ///< no progress over the stagnation window, or true residual stuck above tol
                    ///< (a direct solve's after its refinement steps)
};
/// The status in words ("converged", "iteration limit", ...).
const char* to_string(SolveStatus s);

/// What a solve reports (Solver::solve() and the Krylov functions).
struct SolveResult {
  /// How the solve ended.
  SolveStatus status = SolveStatus::iteration_limit;
  /// Iterations (cycles, corrections) done.
  int iterations = 0;
  double rel_residual = 1.0;       ///< last recursive relative residual
  double true_rel_residual = 1.0;  ///< ||b - A x|| / ||r_0||, computed at the end
  /// Wall time of the solve in seconds (the Krylov methods measure it only when given a
  /// SolveMonitor: 0 otherwise).
  double seconds = 0.0;
  std::string message;  ///< what went wrong, in words (empty when ok)
  double initial_residual = 0.0;  ///< ||r_0|| = ||b - A x_0||, the reference of both ratios
  /// True when the solve converged or ran its fixed iterations.
  bool ok() const { return status == SolveStatus::converged || status == SolveStatus::completed; }
};

/// Thrown by solvers (unless asked not to) when a solve ends without a usable solution.
class SolveError : public Error {
 public:
  /// An error whose what() is r.message.
  explicit SolveError(SolveResult r) : Error(r.message), result(std::move(r)) {}
  /// The failed solve's result (status, iterations, residuals).
  SolveResult result;
};

}  // namespace pmg
