// pmg/multigrid/factory.hpp — the multigrid component's methods in the solver factory
// (pmg/sparse/factory.hpp): pmg and mgpcg (cycles on any mg::LevelProvider), and the smoothers
// gauss-seidel, point-gauss-seidel, chebyshev, patch, damped-jacobi, l1-jacobi and richardson.
//
//   pmg::mg::register_solvers();   // or pmg::register_all_solvers() (<pmg/solvers.hpp>)
//   auto solver = pmg::make_solver(pmg::Config::from_pairs({"method=mgpcg"}, "example"), {&levels});
//
// A cycle's lowest level is `auto` by default: for mgpcg CHOLMOD below kAmgLowestLevelUnknowns,
// BoomerAMG (one V-cycle per cycle, Chebyshev relaxation) from there where the hypre adapter is
// registered; CHOLMOD for pmg and where lowest-level keys are given without a method. Registering
// these also registers the CHOLMOD adapter's method (pmg::cholmod::register_solvers()).
#pragma once

#include "pmg/sparse/defaults.hpp"
#include "pmg/sparse/factory.hpp"

#include <memory>
#include "pmg/sparse/defaults.hpp"

namespace pmg::mg {

/// Registers the multigrid methods and smoothers (idempotent; a name the user registered is kept).
void register_solvers();

class MultigridCycle;
/// The stationary `pmg` method's cycle from its keys (the config of method=pmg) as its concrete
/// type, for studies that drive a cycle's own operations (MultigridCycle::refresh_galerkin);
/// InputError names a key no part of the cycle read. Solvers for solving come from make_solver.
std::unique_ptr<MultigridCycle> make_cycle(const Config& config, const SolverContext& context);

/// The lowest level's size from which `lowest_level=auto` takes BoomerAMG instead of CHOLMOD for
/// mgpcg (levels without node coordinates or a lowest matrix of their own count as 0); its one
/// home is pmg/sparse/defaults.hpp.
using pmg::kAmgLowestLevelUnknowns;
using pmg::kAmgCoarseMeshUnknowns;
using pmg::kAmgCoarseMeshCycles;

/// λ/μ (LevelProvider::lame_ratio()) from which the stationary `pmg` smooths with Chebyshev on
/// vertex patches (smoother.preconditioner=patch) when no smoother key is given: the measured
/// break-even (docs/robustness.md): from ν = 0.49 patches were faster on the quadratic bar, at
/// ν = 0.495 (λ/μ = 99) about even on the cubic Homer (21.6 s against 22.4 s), and from ν = 0.499 the
/// point smoother stagnates there. mgpcg keeps the point smoother: faster in time at every ν
/// measured.
inline constexpr double kPatchLameRatio = 99.0;

/// What `lowest_level=auto` takes for a lowest level of this many unknowns: "boomeramg" from
/// `amg_from` (kAmgLowestLevelUnknowns on a linear level, kAmgCoarseMeshUnknowns on the coarsest of
/// the coarser meshes under one) where a method of that name is registered, "cholmod" otherwise.
std::string choose_lowest_level(index_t unknowns, index_t amg_from = kAmgLowestLevelUnknowns);

/// The BoomerAMG settings of a lowest level `lowest_level=boomeramg` (chosen or by auto), set as
/// defaults under `lc` so the user's keys win: the measured fastest on the quadratic cube's linear
/// level (docs/scaling.md), Chebyshev relaxation (relax_type=16).
void set_amg_lowest_level_defaults(Config& lc);

}  // namespace pmg::mg
