// pmg/multigrid/factory.hpp — one way to build any solver: from a Config (dotted keys or nested
// JSON, pmg/sparse/config.hpp), as AMGCL's runtime make_solver builds from a property tree.
//
//   pmg::Config c = pmg::Config::from_pairs({"method=mgpcg", "tol=1e-6", "smoother.sweeps=3",
//                                            "lowest_level=boomeramg"}, "example");
//   auto solver = pmg::make_solver(c, {&levels});  // levels: any mg::LevelProvider
//   solver->setup(A);
//   solver->solve(b, x);
//
// Every tool (pmg compare, pmg simulate, scene files), example and binding builds its solvers
// here, so every option one of them offers, all offer; docs/solvers.md lists the methods and their
// keys. A key no builder read is an InputError naming it. Adding a solver is one Solver class
// plus one register_solver() call (the built-in ones are registered in factory.cpp).
#pragma once

#include "pmg/multigrid/levels.hpp"
#include "pmg/sparse/config.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/solver.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace pmg {

/// What a solver may need besides its options.
struct SolverContext {
  const mg::LevelProvider* levels = nullptr;  ///< multigrid methods: the level hierarchy
  /// x, y, z of each node of the system (3 unknowns per node, interleaved), where known (FEM
  /// scenes): rigid-body modes for BoomerAMG's interpolation vectors and PETSc GAMG's near-null
  /// space. Must outlive the solvers built with it.
  const std::vector<double>* coordinates = nullptr;
};

/// Builds the solver the config's "method" names (`fallback_method` when it names none) and
/// throws InputError naming any key that was not used. Not set up: call setup(A).
std::unique_ptr<Solver> make_solver(const Config& config, const SolverContext& context = {},
                                    const std::string& fallback_method = "cg");

/// Builds a sub-solver (a preconditioner, smoother or lowest level) from a view of a config,
/// without the unused-key check (the caller's make_solver does it once for the whole tree).
std::unique_ptr<Solver> build_solver(const Config& config, const SolverContext& context,
                                     const std::string& fallback_method);

using SolverBuilder = std::function<std::unique_ptr<Solver>(const Config&, const SolverContext&)>;

struct SolverInfo {
  std::string name;
  std::string description;
  std::string keys;          ///< its options, e.g. "tol max_iterations preconditioner.*"
  bool uses_levels = false;  ///< needs SolverContext::levels
  bool needs_blocks = false; ///< reads 3x3 blocks (BCSR): refuses a scalar system
};

/// Registers a method (replacing one of the same name).
void register_solver(const SolverInfo& info, SolverBuilder builder);
/// Every registered method, in registration order.
std::vector<SolverInfo> registered_solvers();

/// The stopping rule of an iterative method from a config (tol, abs_tol, rhs_floor, max_iterations
/// or fixed_iterations, divergence_limit, stagnation_window, check_every, throw_on_failure) over
/// `defaults`: for the methods registered here and for those registered elsewhere (pmg::gpu).
KrylovParams read_krylov(const Config& config, KrylovParams defaults = {});
/// Those keys but check_every, space-separated, as a SolverInfo's keys list them.
const char* krylov_keys();

/// Whether a method needs a level hierarchy (multigrid, mgpcg) — for tools choosing defaults.
bool method_uses_levels(const std::string& method);
/// Whether a method reads `key` at its top level (per its SolverInfo::keys) — for tools that set a
/// default only where it applies (e.g. rhs_floor for iterative methods).
bool method_accepts_key(const std::string& method, const std::string& key);
/// Whether a method needs 3x3 blocks (a size divisible by 3, given as BCSR).
bool method_needs_blocks(const std::string& method);

}  // namespace pmg
