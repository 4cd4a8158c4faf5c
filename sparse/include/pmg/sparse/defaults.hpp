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
/// The coarsest mesh under a refined mesh's linear level (coarse_meshes) measured the same
/// break-even with BoomerAMG running kAmgCoarseMeshCycles V-cycles there.
inline constexpr index_t kAmgLowestLevelUnknowns = 40000;
/// BoomerAMG's V-cycles per application on the coarsest of coarse_meshes: there the lowest level is
/// solved once per inner cycle, and how exactly decides the outer iterations (the refined cubes of
/// 2.18M, 4.61M and 9.59M unknowns, coarse meshes of 43,554, 91,422 and 188,922 unknowns: CHOLMOD
/// 10, 10 and 10; BoomerAMG with one V-cycle 19-20, 20 and 22, with three 12, 12 and 13), while
/// CHOLMOD's factorisation grows faster than the mesh (docs/scaling.md). On a linear level itself
/// BoomerAMG runs one V-cycle: more took fewer iterations but no shorter solve.
inline constexpr int kAmgCoarseMeshCycles = 3;

}  // namespace pmg
