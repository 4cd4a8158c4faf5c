// pmg/sparse/factory.hpp — one way to build any solver: from a Config (dotted keys or nested
// JSON, pmg/sparse/config.hpp), as AMGCL's runtime make_solver builds from a property tree.
//
//   pmg::register_all_solvers();   // <pmg/solvers.hpp>: every component's methods (or only some)
//   pmg::Config c = pmg::Config::from_pairs({"method=mgpcg", "tol=1e-6", "smoother.degree=4",
//                                            "lowest_level=boomeramg"}, "example");
//   auto solver = pmg::make_solver(c, {&levels});  // levels: any mg::LevelProvider
//   solver->setup(A);
//   solver->solve(b, x);
//
// The registry lives in the solver core (pmg::sparse), which registers the methods it implements
// itself (cg, jacobi-pcg, block-jacobi-pcg, mcg, jacobi, block-jacobi) and links no MPI, hypre,
// PETSc or CHOLMOD. Optional components add theirs: pmg::mg::register_solvers() (pmg, mgpcg and
// the smoothers), pmg::cholmod::, pmg::hypre::, pmg::petsc::, pmg::gpu::register_solvers(), or all
// at once pmg::register_all_solvers() (target pmg::solvers). Registering twice replaces, never
// duplicates.
//
// Each method's keys come from its parameter structs' visit() (pmg/sparse/params.hpp): the same
// function reads them and lists them, so `pmg solvers`, `pmg compare --help` and docs/solvers.md
// are derived from the registry. A key no builder read is an InputError naming it.
#pragma once

#include "pmg/sparse/config.hpp"
#include "pmg/sparse/defaults.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/solver.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace pmg {

class LevelProvider;
struct SaddlePointBlocks;

/// What a solver may need besides its options.
struct SolverContext {
  const LevelProvider* levels = nullptr;  ///< multigrid methods: the level hierarchy
  /// x, y, z of each node of the system (3 unknowns per node, interleaved), where known (FEM
  /// scenes): rigid-body modes for BoomerAMG's interpolation vectors and PETSc GAMG's near-null
  /// space. Must outlive the solvers built with it.
  const std::vector<double>* coordinates = nullptr;
  /// Methods that run across MPI ranks (petsc-mgpcg): their communicator as MPI's Fortran handle
  /// (MPI_Comm_c2f(), mpi4py's Comm.py2f()), which keeps this header free of mpi.h; -1: the
  /// world communicator. Other methods ignore it.
  long communicator = -1;
  /// Smoothers a multigrid cycle builds: the level they smooth (levels->level_name(level)); -1
  /// elsewhere (a level's own data, such as vertex patches, is then the finest level's).
  int level = -1;
  /// Saddle-point methods (mixed-minres): the blocks of the system [A Bᵀ; B -C] they are set up on,
  /// `levels` then being the displacement block's levels. Must outlive the solvers built with it.
  const SaddlePointBlocks* saddle_point = nullptr;
};

/// Builds the solver the config's "method" names (`fallback_method` when it names none) and
/// throws InputError naming any key that was not used. Not set up: call setup(A).
///
/// Two keys belong to make_solver itself (factory_keys()): `layout` (interleaved | component:
/// ComponentLayout, pmg/sparse/layout.hpp) and `unused_keys` — `error` (the default: a key no
/// builder read is an InputError), `known` (a key that some registered method reads, such as tol
/// given to cholmod, may go unused: one option set for a loop over methods; any other key is still
/// an error) or `ignore`. Config::unused_keys() then lists what was left unused.
std::unique_ptr<Solver> make_solver(const Config& config, const SolverContext& context = {},
                                    const std::string& fallback_method = kDefaultMethod);

/// What make_solver does to a built solver `s` for the matrix it will be set up on: under
/// `layout=component` wraps it in ComponentLayout; without levels in `context`, a method reading 3x3
/// blocks (or cg with a block preconditioner) in BlockInput, which reads a scalar Csr as blocks or
/// refuses it (pmg/sparse/layout.hpp); anything else is returned as it is. For a caller that builds
/// with build_solver() and checks its keys itself (a study).
std::unique_ptr<Solver> adapt_to_input(std::unique_ptr<Solver> s, const Config& config, const SolverContext& context,
                                       const std::string& fallback_method = kDefaultMethod);

/// make_solver's check after its build, for a caller that reads a method's parameters itself
/// (read_params): throws InputError naming every key of `config` nobody read, as `unused_keys`
/// (read here) allows.
void check_keys_used(const Config& config);
/// Whether the tree's `unused_keys` (error, the default | known | ignore) accepts options that a
/// library behind a method does not read (PETSc's options left unused).
bool unused_options_allowed(const Config& config);

/// The keys make_solver reads for every method (layout, unused_keys), as SolverInfo lists keys.
std::vector<KeyInfo> factory_keys();

/// Builds a sub-solver (a preconditioner, smoother or lowest level) from a view of a config,
/// without the unused-key check (the caller's make_solver does it once for the whole tree).
std::unique_ptr<Solver> build_solver(const Config& config, const SolverContext& context,
                                     const std::string& fallback_method);

/// Builds one method from its options and context.
using SolverBuilder = std::function<std::unique_ptr<Solver>(const Config&, const SolverContext&)>;

/// A registered method.
struct SolverInfo {
  std::string name;                ///< the "method" value
  std::string description;         ///< one line
  std::vector<KeyInfo> keys;       ///< its options (from its parameter structs' visit())
  bool uses_levels = false;        ///< needs SolverContext::levels
  bool needs_blocks = false;       ///< reads 3x3 blocks (BCSR): refuses a scalar system
  std::string component = "core";  ///< the library that registered it (core, multigrid, cholmod, hypre, petsc, gpu)
  /// Process-wide start-up of the library behind the method (MPI for hypre, PETSc's
  /// initialisation), run by start_libraries() before any clock starts; empty when there is none.
  std::function<void()> start;
  /// Runs across MPI ranks on each rank's part of an FEM model: FEM callers step it with their
  /// distributed stepper (sim::DynamicRun), never with the serial one.
  bool across_ranks = false;

  SolverInfo() = default;
  /// Every field in declaration order; the trailing ones default as above.
  SolverInfo(std::string name_, std::string description_, std::vector<KeyInfo> keys_ = {},
             bool uses_levels_ = false, bool needs_blocks_ = false, std::string component_ = "core",
             std::function<void()> start_ = {}, bool across_ranks_ = false)
      : name(std::move(name_)), description(std::move(description_)), keys(std::move(keys_)),
        uses_levels(uses_levels_), needs_blocks(needs_blocks_), component(std::move(component_)),
        start(std::move(start_)), across_ranks(across_ranks_) {}
};

/// Registers a method (replacing one of the same name).
void register_solver(const SolverInfo& info, SolverBuilder builder);
/// Registers a method unless one of that name exists: how the components register theirs, so that a
/// user's own registration of a name wins whether it came before or after the component's.
void register_builtin_solver(const SolverInfo& info, SolverBuilder builder);
/// Every registered method, in registration order.
std::vector<SolverInfo> registered_solvers();
/// The registered method of that name; throws InputError listing the registered ones otherwise.
SolverInfo solver_info(const std::string& method);

/// Runs the start-up hook of every method the config names (any "method" key of the tree, e.g.
/// lowest_level.method=boomeramg) once per process: MPI and PETSc are started before the solvers'
/// clocks, so that no solver is charged for them. Returns the seconds taken, or -1 when no named
/// method has a start-up.
double start_libraries(const Config& config);

/// The stopping rule of an iterative method from a config (the keys of KrylovParams::visit) over
/// `defaults`: for the methods registered here and for those registered elsewhere (pmg::gpu).
KrylovParams read_krylov(const Config& config, KrylovParams defaults = {});
/// Those keys with their defaults, as SolverInfo lists them.
std::vector<KeyInfo> krylov_keys(KrylovParams defaults = {});
/// The merged CG's extra key (check_every) over `defaults`.
std::vector<KeyInfo> check_every_key(KrylovParams defaults = {});

/// Whether a method needs a level hierarchy (multigrid, mgpcg) — for tools choosing defaults.
bool method_uses_levels(const std::string& method);
/// Whether a method reads `key` at its top level (per its SolverInfo::keys) — for tools that set a
/// default only where it applies (e.g. rhs_floor for iterative methods).
bool method_accepts_key(const std::string& method, const std::string& key);
/// Whether a method needs 3x3 blocks (a size divisible by 3, given as BCSR).
bool method_needs_blocks(const std::string& method);

}  // namespace pmg
