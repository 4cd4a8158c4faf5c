// Multigrid levels as files: read a user's level matrices and prolongations (Matrix Market), so
// PMG and MGPCG run on systems from any code; export an FEM scene's levels in the same form.
#pragma once

#include "scene.hpp"

#include "pmg/fem/pmg_cycle.hpp"
#include "pmg/multigrid/cycle.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg::tools {

struct UserLevels {
  std::vector<Bcsr> matrices;                                ///< coarsest first
  std::vector<std::unique_ptr<mg::BlockTransfer>> transfers;  ///< transfers[l-1]: level l-1 -> l
};

/// matrices: coarsest first, sizes multiples of 3 (3 unknowns per node, interleaved);
/// prolongations[l-1]: scalar, (nodes of level l) x (nodes of level l-1). Sizes are checked.
UserLevels read_levels(const std::vector<std::string>& matrices,
                       const std::vector<std::string>& prolongations);

/// A cycle over user levels: block Gauss–Seidel smoothers (options.smoother), R = Pᵀ, the
/// options' cycle and lowest-level solver (the FEM-only options are not used).
std::unique_ptr<mg::MultigridCycle> make_cycle(const UserLevels& levels, const fem::PmgOptions& options);

/// The tools' names of the lowest-level solvers ("cholmod", "boomeramg", "boomeramg-pcg") into
/// options, with the AMG cycles per application and boomeramg-pcg's tolerance.
void set_lowest_level(fem::PmgOptions& options, const std::string& name, int amg_cycles, double tol);

/// Writes DIR/A<l>.mtx (level matrices over the free dofs, symmetric), DIR/P<l>.mtx (scalar
/// prolongations) and DIR/b.mtx; assembles the lower levels first.
void export_levels(FemSystem& system, const std::string& dir);

}  // namespace pmg::tools
