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

struct IterationRecord {
  int iteration;        ///< 0 is the initial residual
  double seconds;       ///< wall time since start()
  double rel_residual;  ///< ||r_i|| / ||r_0||
};

class SolveMonitor {
 public:
  /// Resets the history and starts the clock.
  void start();
  void record(int iteration, double rel_residual);
  double elapsed() const;
  const std::vector<IterationRecord>& history() const { return history_; }
  /// Optional observer, called after every record (progress output, custom stopping logic).
  std::function<void(const IterationRecord&)> on_record;

 private:
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  std::vector<IterationRecord> history_;
};

enum class SolveStatus {
  converged,        ///< relative residual (recursive and true) below the tolerance
  completed,        ///< fixed-iteration mode ran its iterations
  iteration_limit,  ///< tolerance not reached within max_iterations
  breakdown,        ///< a division by a non-positive curvature: operator or preconditioner not SPD
  diverged,         ///< relative residual above the divergence limit
  non_finite,       ///< NaN or Inf appeared
  stagnated,        ///< no progress over the stagnation window, or true residual stuck above tol
};
const char* to_string(SolveStatus s);

struct SolveResult {
  SolveStatus status = SolveStatus::iteration_limit;
  int iterations = 0;
  double rel_residual = 1.0;       ///< last recursive relative residual
  double true_rel_residual = 1.0;  ///< ||b - A x|| / ||r_0||, computed at the end
  double seconds = 0.0;
  std::string message;  ///< what went wrong, in words (empty when ok)
  double initial_residual = 0.0;  ///< ||r_0|| = ||b - A x_0||, the reference of both ratios
  bool ok() const { return status == SolveStatus::converged || status == SolveStatus::completed; }
};

/// Thrown by solvers (unless asked not to) when a solve ends without a usable solution.
class SolveError : public Error {
 public:
  explicit SolveError(SolveResult r) : Error(r.message), result(std::move(r)) {}
  SolveResult result;
};

}  // namespace pmg
