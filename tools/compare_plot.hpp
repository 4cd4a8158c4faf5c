// pmg compare --plot: a run's residual histories and work-precision points drawn by
// tools/plot_history.py (matplotlib, Debian's python3), through temporary files.
#pragma once

#include "pmg/study/study.hpp"

#include <string>
#include <vector>

namespace pmg::tools {

/// The plot's per-solver summary (a work-precision point each): `seconds` the time to the
/// tolerance including set-up (the table's set-up + solve; empty for a failed solver), `error` the
/// table's error against the reference (empty: none), `rel_residual` the true residual at the end.
std::string summary_csv(const std::vector<study::SolverRun>& runs);

/// --plot: relative residual against time and iterations, and error against time. Its data is the
/// --history file where one was given, else a temporary copy; the per-solver summary is always
/// temporary: nothing but the PNG is left behind. Throws Error when the script fails.
void plot(const std::vector<study::SolverRun>& runs, const std::string& history, const std::string& png,
          const std::string& title);

}  // namespace pmg::tools
