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
/// the reference of pmg compare and the lowest level of a cycle below kAmgLowestLevelUnknowns
/// (kAmgCoarseMeshUnknowns on the coarsest of a refined mesh's coarser meshes).
inline constexpr const char* kDefaultDirectMethod = "cholmod";
/// A scene's time steps.
inline constexpr const char* kDefaultDynamicMethod = "pmg";

/// The linear level's size (unknowns) from which `lowest_level=auto` takes AMG (BoomerAMG, one
/// V-cycle) instead of CHOLMOD for mgpcg in one process: the measured break-even of a whole MGPCG
/// solve (set-up included) on the unrefined quadratic cube, static and in corotational time steps
/// (docs/scaling.md, "The break-even, again": BoomerAMG ahead from about 12,000 unknowns static,
/// from about 22,000 in time steps; the quadratic Bunny's 14,262 keep CHOLMOD).
inline constexpr index_t kAmgLowestLevelUnknowns = 20000;
/// On a mesh made by refinement: the linear level's size from which `coarse_meshes=auto` solves
/// it by a cycle over the coarser meshes, and the coarsest mesh's size from which `auto` takes
/// BoomerAMG (kAmgCoarseMeshCycles V-cycles) there instead of CHOLMOD (docs/scaling.md: CHOLMOD
/// still the faster at 12,000 and 21,450 coarse unknowns).
inline constexpr index_t kAmgCoarseMeshUnknowns = 40000;
/// Across MPI ranks (dist::DistributedMgpcg, petsc::PcmgParams): the lowest level's global size
/// from which `auto` takes BoomerAMG instead of MUMPS (the serial break-even before 2026-12-08;
/// not measured across ranks).
inline constexpr index_t kAmgAcrossRanksUnknowns = 40000;
/// BoomerAMG's V-cycles per application on the coarsest of coarse_meshes: there the lowest level is
/// solved once per inner cycle, and how exactly decides the outer iterations (the refined cubes of
/// 2.18M, 4.61M and 9.59M unknowns, coarse meshes of 43,554, 91,422 and 188,922 unknowns: CHOLMOD
/// 10, 10 and 10; BoomerAMG with one V-cycle 19-20, 20 and 22, with three 12, 12 and 13), while
/// CHOLMOD's factorisation grows faster than the mesh (docs/scaling.md). On a linear level itself
/// BoomerAMG runs one V-cycle: more took fewer iterations but no shorter solve.
inline constexpr int kAmgCoarseMeshCycles = 3;

}  // namespace pmg
