// pmg/sparse/defaults.hpp — the one home of the defaults that more than one component chooses: the
// method per use and the AMG break-even. Code, help texts (built from these constants) and the
// generated docs/solvers.md read them here.
#pragma once

#include "pmg/sparse/types.hpp"

namespace pmg {

/// The method for a system given as a matrix alone (pmg::make_solver's fallback, pmg compare's
/// --set without a method, pmgkit.make_solver).
inline constexpr const char* kDefaultMethod = "cg";
/// The method for a system with levels (a degree hierarchy or user levels: pmgkit.multigrid,
/// pmgkit's FEM systems).
inline constexpr const char* kDefaultLevelsMethod = "mgpcg";
/// The direct method: a static solve on one model (fem::solve_static), a scene's static solve,
/// the reference of pmg compare and the lowest level of a cycle below kAmgLowestLevelUnknowns.
inline constexpr const char* kDefaultDirectMethod = "cholmod";
/// A scene's time steps.
inline constexpr const char* kDefaultDynamicMethod = "pmg";

/// The lowest level's size (global unknowns) from which `lowest_level=auto` takes AMG (BoomerAMG)
/// instead of a direct solve (CHOLMOD serially, MUMPS across ranks): the measured break-even of a
/// whole MGPCG solve (set-up included) on the quadratic cube (docs/scaling.md, with its command).
inline constexpr index_t kAmgLowestLevelUnknowns = 40000;
/// The same for the coarsest mesh under a refined mesh's linear level (coarse_meshes): there the
/// lowest level is solved once per inner cycle, and an exact solve halves the outer iterations
/// (20 -> 10, 20 -> 9 on the refined cubes of 2.18M and 4.61M unknowns, coarse meshes of 43,554 and
/// 91,422 unknowns; t(1e-6) against BoomerAMG's, pair by pair on a noisy VM: 1.11x and 0.75x at
/// 2.18M, 0.93x and 0.52x at 4.61M), where at 188,922 unknowns CHOLMOD's factorisation cost about
/// what its 12 fewer iterations saved (docs/scaling.md).
inline constexpr index_t kAmgCoarseMeshUnknowns = 120000;

}  // namespace pmg
