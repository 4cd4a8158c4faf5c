#include "pmg/sparse/monitor.hpp"
#include "pmg/sparse/timer.hpp"

namespace pmg {

void SolveMonitor::start() {
  history_.clear();
  t0_ = Clock::now();
}

double SolveMonitor::elapsed() const {
  return seconds_since(t0_);
}

void SolveMonitor::record(int iteration, double rel_residual) {
  history_.push_back({iteration, elapsed(), rel_residual});
  if (on_record) on_record(history_.back());
}

const char* to_string(SolveStatus s) {
  switch (s) {
    case SolveStatus::converged: return "converged";
    case SolveStatus::completed: return "completed";
    case SolveStatus::iteration_limit: return "iteration limit";
    case SolveStatus::breakdown: return "breakdown";
    case SolveStatus::diverged: return "diverged";
    case SolveStatus::non_finite: return "non-finite";
    case SolveStatus::stagnated: return "stagnated";
  }
  return "unknown";
}

}  // namespace pmg
