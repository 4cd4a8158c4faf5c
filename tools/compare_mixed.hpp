// pmg compare --formulation mixed: the mixed displacement–pressure system (pmg/fem/mixed.hpp) of a
// compare scene, solved by each named solver (mixed-gmres, mixed-minres, a direct method on the assembled
// saddle point), with set-up and solve times, true residuals and the answers' differences.
#pragma once

#include "scene.hpp"

#include "pmg/sparse/config.hpp"

#include <string>
#include <utility>
#include <vector>

namespace pmg::tools {

/// Registers --formulation displacement|mixed on pmg compare.
void add_formulation_option(CLI::App* sub, std::string& formulation);

/// Runs every (name, config) on the scene's mixed system and prints one row each; writes the
/// rows to `json_report` (atomically) when it is not empty. Throws Exit{kSolveFailed} after the
/// table when a solve failed, InputError for a scene the mixed formulation cannot take.
void run_mixed(const SceneOptions& scene, const std::vector<std::pair<std::string, Config>>& configs,
               const std::string& json_report);

}  // namespace pmg::tools
