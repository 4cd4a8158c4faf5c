// pmg/sparse/timer.hpp — the wall clock every timing in pmgkit reads (set-up and solve times,
// stage breakdowns, reports): std::chrono::steady_clock, in seconds.
#pragma once

#include <chrono>

namespace pmg {

/// The clock of every timing (monotonic).
using Clock = std::chrono::steady_clock;

/// Seconds elapsed since t0.
inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace pmg
