// The solver factory: every built-in method registered once, each reading its own keys.
#include "pmg/multigrid/factory.hpp"

#include "pmg/multigrid/boomeramg.hpp"
#include "pmg/multigrid/chebyshev.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/petsc.hpp"
#include "pmg/sparse/cholmod_solver.hpp"
#include "pmg/sparse/krylov.hpp"

#include <iterator>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

namespace pmg {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxInt = std::numeric_limits<int>::max();

// ---- shared readers ------------------------------------------------------------------------------


mg::BoomerAMGParams read_boomeramg(const Config& c) {
  mg::BoomerAMGParams p;
  p.cycles = c.get_int("cycles", p.cycles, 1, 1000);
  p.num_functions = c.get_int("num_functions", p.num_functions, 1, 64);
  p.nodal = c.get_int("nodal", p.nodal, 0, 6);
  p.nodal_diag = c.get_int("nodal_diag", p.nodal_diag, 0, 2);
  p.strong_threshold = c.get_double("strong_threshold", p.strong_threshold, 1e-6, 1 - 1e-6);
  p.coarsen_type = c.get_int("coarsen_type", p.coarsen_type, 0, 22);
  p.interp_type = c.get_int("interp_type", p.interp_type, 0, 100);
  p.p_max_elements = c.get_int("p_max", p.p_max_elements, 0, 1000);
  p.trunc_factor = c.get_double("trunc_factor", p.trunc_factor, 0.0, 1.0);
  p.relax_type = c.get_int("relax_type", p.relax_type, 0, 100);
  p.relax_coarse = c.get_int("relax_coarse", p.relax_coarse, 0, 100);
  p.relax_order = c.get_int("relax_order", p.relax_order, 0, 1);
  p.sweeps = c.get_int("sweeps", p.sweeps, 1, 100);
  p.agg_levels = c.get_int("agg_levels", p.agg_levels, 0, 100);
  p.agg_interp_type = c.get_int("agg_interp_type", p.agg_interp_type, 1, 8);
  p.max_levels = c.get_int("max_levels", p.max_levels, 2, 100);
  p.max_coarse_size = c.get_int("max_coarse_size", p.max_coarse_size, 1, 1000000);
  p.interp_vectors = c.get_choice("interp_vectors", "none", {"none", "rigid"}) == "rigid" ? 3 : 0;
  p.interp_vec_variant = c.get_int("interp_vec_variant", p.interp_vec_variant, 1, 3);
  return p;
}

/// BoomerAMG with the context's node coordinates (for rigid-body interpolation vectors).
std::unique_ptr<mg::BoomerAMG> make_boomeramg(const Config& c, const SolverContext& ctx) {
  auto amg = std::make_unique<mg::BoomerAMG>(read_boomeramg(c));
  if (amg->params().interp_vectors > 0) {
    if (!ctx.coordinates)
      c.fail("interp_vectors", "rigid needs node coordinates: an FEM scene (--box or --mesh) provides "
                               "them; a matrix read from a file does not");
    amg->set_coordinates(*ctx.coordinates);
  }
  return amg;
}

/// A PETSc preconditioner (GAMG, or a Cholesky factorisation by MUMPS or CHOLMOD).
std::unique_ptr<mg::PetscPreconditioner> make_petsc(const Config& c, const SolverContext& ctx,
                                                    const std::string& type) {
  mg::PetscParams p;
  p.type = type;
  bool rigid = false;
  if (type == "gamg") {
    const std::string nns = c.get_choice("near_null_space", "auto", {"auto", "rigid", "none"});
    if (nns == "rigid" && !ctx.coordinates)
      c.fail("near_null_space", "rigid needs node coordinates: an FEM scene (--box or --mesh) provides "
                                "them; a matrix read from a file does not (auto: rigid where known)");
    rigid = nns != "none" && ctx.coordinates;
  }
  p.rigid_near_null_space = rigid;
  p.options = c.get_string("options", "");
  auto s = std::make_unique<mg::PetscPreconditioner>(p);
  if (rigid) s->set_coordinates(*ctx.coordinates);
  return s;
}

/// A smoother: a Smoother method, or any other solver used as Richardson's preconditioner.
std::unique_ptr<mg::Smoother> build_smoother(const Config& c, const SolverContext& ctx) {
  std::unique_ptr<Solver> s = build_solver(c, ctx, "gauss-seidel");
  if (auto* sm = dynamic_cast<mg::Smoother*>(s.get())) {
    s.release();
    return std::unique_ptr<mg::Smoother>(sm);
  }
  return std::make_unique<mg::Richardson>(std::move(s));
}

/// Chebyshev's keys: its registration reads them, and operator=auto takes a smoother given only
/// these (no method) for Chebyshev.
const char* kChebyshevKeys = "degree kind lower_fraction power_iterations update_iterations";

/// The multigrid cycle's keys (cycle, cycles, coarse_operator, restriction, operator, smoother.*,
/// lowest_level.*); `cycles` defaults to `default_cycles`, `operator` to "auto" (for PMG and MGPCG:
/// the matrix-free cycle was the faster on every system measured, README, matrix-free section; the
/// seed's scenes and tables name `operator=assembled`).
std::unique_ptr<mg::MultigridCycle> build_cycle(const Config& c, const SolverContext& ctx,
                                                int default_cycles, const KrylovParams& iteration) {
  if (!ctx.levels || ctx.levels->num_levels() < 2)
    c.fail("method", "multigrid needs at least two levels: an FEM scene of degree >= 2, or level "
                     "matrices with prolongations");
  mg::MultigridParams p;
  p.gamma = c.get_choice("cycle", "V", {"V", "W"}) == "W" ? 2 : 1;
  p.coarse_operator = c.get_choice("coarse_operator", "geometric", {"geometric", "galerkin"}) == "galerkin"
                          ? mg::CoarseOperator::galerkin
                          : mg::CoarseOperator::geometric;
  Config sc = c.child("smoother");
  const std::string op =
      c.get_choice("operator", "auto", {"auto", "assembled", "matrix-free"});
  p.matrix_free = op == "matrix-free";
  if (op == "auto") {
    // Matrix-free where the levels offer operators and nothing asks for matrices: geometric lower
    // levels, and no smoother chosen other than Chebyshev (Gauss–Seidel's keys, say, keep the
    // assembled route the configuration was written for).
    bool chebyshev = true;  // the smoother named Chebyshev, or given only Chebyshev's keys
    if (sc.has("method")) {
      chebyshev = sc.get_string("method", "") == "chebyshev";
    } else {
      std::istringstream list(kChebyshevKeys);
      const std::set<std::string> keys{std::istream_iterator<std::string>(list), {}};
      for (const auto& [key, value] : sc.items())
        if (!keys.count(key.substr(sc.full_key("").size()))) chebyshev = false;
    }
    p.matrix_free = ctx.levels->offers_matrix_free() &&
                    p.coarse_operator == mg::CoarseOperator::geometric && chebyshev;
    // Said in the solver's printed options: the route taken is part of what was run.
    if (p.matrix_free) Config(c).set("operator", "matrix-free");
  }
  // Matrix-free MGPCG: one cycle per application was the fastest measured (README, matrix-free
  // table); the assembled route keeps the seed's two.
  p.cycles = c.get_int("cycles", p.matrix_free ? 1 : default_cycles, 1, 100);
  p.interpolating_restriction =
      c.get_choice("restriction", "transpose", {"transpose", "interpolating"}) == "interpolating";
  p.iteration = iteration;
  if (p.matrix_free) {
    if (p.coarse_operator == mg::CoarseOperator::galerkin)
      c.fail("operator", "matrix-free levels need coarse_operator=geometric (Galerkin products are matrices)");
    for (int l = 1; l < ctx.levels->num_levels(); ++l)
      if (!ctx.levels->matrix_free_operator(l))
        c.fail("operator", "matrix-free needs levels with matrix-free operators (an FEM scene's degree "
                           "hierarchy has them for degree >= 2); these levels have none");
    // Gauss–Seidel needs the matrix's entries: Chebyshev needs only products and the diagonal, and
    // its eigenvalue estimate is refreshed per update by one power iteration warm-started from the
    // last estimate (a time step moves the spectrum little: three took 10-15 ms more per twisted
    // Homer step for the same iterations). The optimised fourth kind of degree 3 was as fast as the
    // best of the measured variants on Homer and the cube and needs no lower bound (README).
    sc.set_default("method", "chebyshev");
    if (sc.get_string("method", "chebyshev") == "chebyshev") {
      sc.set_default("kind", "opt-fourth");
      sc.set_default("degree", "3");
      sc.set_default("update_iterations", "1");
    }
  }
  Config lc = c.child("lowest_level");
  // The linear level solved by CG to a loose tolerance: a usable correction even when the inner
  // solve stops early (the outer iteration judges it); only a broken one is an error.
  const std::string lm = lc.get_string("method", "cholmod");
  // The linear level's factorisation and solves run between the OpenMP kernels of the cycle: a
  // threaded BLAS's spinning workers would take a core from them (CholmodSolver, blas_threads).
  // Its factorisations are threaded (0: the BLAS's own count), its workers ended after each.
  if (lm == "cholmod") {
    lc.set_default("blas_threads", "1");
    lc.set_default("factor_threads", "0");
  }
  if (lm == "cg" || lm == "boomeramg-pcg") {
    lc.set_default("tol", "0.1");
    lc.set_default("max_iterations", "500");
    lc.set_default("throw_on_failure", "false");
  }
  // One smoother per level, built from the same options (read once per level: same keys).
  std::vector<std::unique_ptr<mg::Smoother>> smoothers;
  for (int l = 1; l < ctx.levels->num_levels(); ++l) smoothers.push_back(build_smoother(sc, ctx));
  // The lowest level is a system of its own: its nodes' coordinates (where the levels know them),
  // not the finest level's.
  const std::vector<double> lowest_xyz = ctx.levels->node_coordinates(0);
  SolverContext lowest_ctx = ctx;
  lowest_ctx.coordinates = lowest_xyz.empty() ? nullptr : &lowest_xyz;
  auto lowest = build_solver(lc, lowest_ctx, "cholmod");
  return std::make_unique<mg::MultigridCycle>(
      *ctx.levels, p, [&](int l) { return std::move(smoothers[l - 1]); }, std::move(lowest));
}

std::unique_ptr<Solver> pcg_with(const Config& c, std::unique_ptr<Solver> M) {
  return std::make_unique<Cg>(read_krylov(c), std::move(M));
}

// ---- the registry --------------------------------------------------------------------------------

struct Entry {
  SolverInfo info;
  SolverBuilder build;
};

struct Registry {
  std::vector<Entry> entries;
  std::mutex mutex;
  Registry();
  const Entry* find(const std::string& name) {
    for (const auto& e : entries)
      if (e.info.name == name) return &e;
    return nullptr;
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

const char* kKrylovKeys = "tol abs_tol rhs_floor max_iterations fixed_iterations divergence_limit "
                          "stagnation_window throw_on_failure";
const char* kCycleKeys = "cycle cycles coarse_operator restriction operator smoother.* lowest_level.*";
const char* kAmgKeys = "cycles num_functions nodal nodal_diag strong_threshold coarsen_type interp_type p_max "
                       "trunc_factor relax_type relax_coarse relax_order sweeps agg_levels agg_interp_type "
                       "max_levels max_coarse_size interp_vectors interp_vec_variant";

Registry::Registry() {
  auto add = [&](SolverInfo info, SolverBuilder b) { entries.push_back({std::move(info), std::move(b)}); };
  // Krylov methods
  add({"cg", "conjugate gradients, optionally preconditioned by any fixed symmetric solver",
       std::string(kKrylovKeys) + " preconditioner.*"},
      [](const Config& c, const SolverContext& ctx) {
        std::unique_ptr<Solver> M;
        if (c.has_child("preconditioner") || c.has("preconditioner"))
          M = build_solver(c.child("preconditioner"), ctx, "block-jacobi");
        return pcg_with(c, std::move(M));
      });
  add({"jacobi-pcg", "CG preconditioned by point Jacobi", kKrylovKeys},
      [](const Config& c, const SolverContext&) { return pcg_with(c, std::make_unique<JacobiPreconditioner>()); });
  add({"block-jacobi-pcg", "CG preconditioned by 3x3 block Jacobi", kKrylovKeys, false, true},
      [](const Config& c, const SolverContext&) { return pcg_with(c, std::make_unique<BlockJacobiPreconditioner>()); });
  add({"mcg", "merged CG (three fused steps) with block Jacobi", std::string(kKrylovKeys) + " check_every",
       false, true},
      [](const Config& c, const SolverContext&) { return std::make_unique<MergedCg>(read_krylov(c)); });
  add({"boomeramg-pcg", "CG preconditioned by hypre BoomerAMG V-cycles", std::string(kKrylovKeys) + " " + kAmgKeys},
      [](const Config& c, const SolverContext& ctx) {
        KrylovParams k = read_krylov(c);
        return std::make_unique<Cg>(k, make_boomeramg(c, ctx));
      });
  // Multigrid
  add({"pmg", "stationary multigrid: one cycle per iteration", std::string(kKrylovKeys) + " " + kCycleKeys, true,
       true},
      [](const Config& c, const SolverContext& ctx) { return build_cycle(c, ctx, 1, read_krylov(c)); });
  add({"mgpcg", "CG preconditioned by multigrid cycles (cycles: per application, default 2)",
       std::string(kKrylovKeys) + " " + kCycleKeys, true, true},
      [](const Config& c, const SolverContext& ctx) {
        const KrylovParams k = read_krylov(c);
        return std::make_unique<Cg>(k, build_cycle(c, ctx, 2, KrylovParams{}));
      });
  // Direct and algebraic multigrid
  add({"cholmod", "sparse Cholesky (CHOLMOD, supernodal): symbolic once, numeric per update",
       "ordering blas_threads factor_threads"},
      [](const Config& c, const SolverContext&) {
        return std::make_unique<CholmodSolver>(c.get_choice("ordering", "metis", {"metis", "auto", "amd", "nesdis"}),
                                               c.get_int("blas_threads", 0, 0, 4096),
                                               c.get_int("factor_threads", -1, -1, 4096));
      });
  add({"boomeramg", "hypre BoomerAMG V-cycles (a fixed symmetric operator)", kAmgKeys},
      [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> { return make_boomeramg(c, ctx); });
  // PETSc (built when PETSc is found; otherwise these say so)
  add({"gamg-pcg", "CG preconditioned by PETSc's GAMG (smoothed aggregation, rigid-body near-null space)",
       std::string(kKrylovKeys) + " near_null_space options"},
      [](const Config& c, const SolverContext& ctx) {
        KrylovParams k = read_krylov(c);
        return std::make_unique<Cg>(k, make_petsc(c, ctx, "gamg"));
      });
  add({"gamg", "PETSc GAMG V-cycles (a fixed symmetric operator)", "near_null_space options"},
      [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> { return make_petsc(c, ctx, "gamg"); });
  add({"mumps", "sparse Cholesky by MUMPS, through PETSc", "options"},
      [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> { return make_petsc(c, ctx, "mumps"); });
  add({"petsc-cholmod", "sparse Cholesky by CHOLMOD, through PETSc (to compare with our CHOLMOD adapter)",
       "options"},
      [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
        return make_petsc(c, ctx, "cholmod");
      });
  // Preconditioners and smoothers
  add({"jacobi", "point Jacobi D^-1", ""},
      [](const Config&, const SolverContext&) { return std::make_unique<JacobiPreconditioner>(); });
  add({"block-jacobi", "3x3 block Jacobi D^-1", "", false, true},
      [](const Config&, const SolverContext&) { return std::make_unique<BlockJacobiPreconditioner>(); });
  auto gauss_seidel = [](bool pointwise) {
    return [pointwise](const Config& c, const SolverContext&) {
      mg::GaussSeidelParams p;
      p.pointwise = pointwise;
      p.sweeps = c.get_int("sweeps", p.sweeps, 0, 1000);
      p.ordering = c.get_choice("ordering", "multicolor", {"multicolor", "natural"}) == "natural"
                       ? mg::Ordering::natural
                       : mg::Ordering::multicolor;
      return std::make_unique<mg::BlockGaussSeidel>(p);
    };
  };
  add({"gauss-seidel", "3x3-block Gauss-Seidel (forward pre-, backward post-smoothing)", "sweeps ordering",
       false, true},
      gauss_seidel(false));
  add({"point-gauss-seidel", "scalar Gauss-Seidel inside 3x3 block rows", "sweeps ordering", false, true},
      gauss_seidel(true));
  add({"chebyshev", "Chebyshev polynomial on D^-1 A (3x3 blocks D)", kChebyshevKeys, false, true},
      [](const Config& c, const SolverContext&) {
        mg::ChebyshevParams p;
        p.degree = c.get_int("degree", p.degree, 1, 100);
        const std::string kind = c.get_choice("kind", "first", {"first", "fourth", "opt-fourth"});
        p.kind = kind == "first" ? mg::ChebyshevKind::first
                 : kind == "fourth" ? mg::ChebyshevKind::fourth
                                    : mg::ChebyshevKind::optimal_fourth;
        p.lower_fraction = c.get_double("lower_fraction", p.lower_fraction, 1e-6, 1 - 1e-6);
        p.power_iterations = c.get_int("power_iterations", p.power_iterations, 1, 1000);
        p.update_iterations = c.get_int("update_iterations", p.update_iterations, 0, 1000);
        return std::make_unique<mg::Chebyshev>(p);
      });
  add({"damped-jacobi", "damped 3x3 block Jacobi x += omega D^-1 (b - A x)", "sweeps omega", false, true},
      [](const Config& c, const SolverContext&) {
        mg::JacobiParams p;
        p.sweeps = c.get_int("sweeps", p.sweeps, 0, 1000);
        p.omega = c.get_double("omega", p.omega, 1e-6, 2.0);
        return std::make_unique<mg::BlockJacobi>(p);
      });
  add({"l1-jacobi", "l1 block Jacobi x += (D + l1 row sums)^-1 (b - A x): no damping to tune", "sweeps", false,
       true},
      [](const Config& c, const SolverContext&) {
        mg::JacobiParams p;
        p.sweeps = c.get_int("sweeps", 2, 0, 1000);
        p.omega = 1.0;
        p.l1 = true;
        return std::make_unique<mg::BlockJacobi>(p);
      });
  add({"richardson", "x += omega M (b - A x) with any solver M", "iterations omega preconditioner.*"},
      [](const Config& c, const SolverContext& ctx) {
        mg::RichardsonParams p;
        p.iterations = c.get_int("iterations", p.iterations, 0, 1000);
        p.omega = c.get_double("omega", p.omega, 1e-6, 2.0);
        return std::make_unique<mg::Richardson>(build_solver(c.child("preconditioner"), ctx, "block-jacobi"), p);
      });
}

}  // namespace

KrylovParams read_krylov(const Config& c, KrylovParams p) {
  p.rel_tol = c.get_double("tol", p.rel_tol, 0.0, 1.0);
  if (!(p.rel_tol < 1.0)) c.fail("tol", "must be < 1");
  p.abs_tol = c.get_double("abs_tol", p.abs_tol, 0.0, kInf);
  p.rhs_floor = c.get_double("rhs_floor", p.rhs_floor, 0.0, 1.0);
  p.max_iterations = c.get_int("max_iterations", p.max_iterations, 1, kMaxInt);
  const int fixed = c.get_int("fixed_iterations", 0, 0, kMaxInt);
  if (fixed > 0) {
    if (c.has("max_iterations")) c.fail("fixed_iterations", "give either fixed_iterations or max_iterations");
    p.max_iterations = fixed;
    p.fixed_iterations = true;
  }
  p.divergence_limit = c.get_double("divergence_limit", p.divergence_limit, 1.0, kInf);
  p.stagnation_window = c.get_int("stagnation_window", p.stagnation_window, 0, kMaxInt);
  p.check_every = c.get_int("check_every", p.check_every, 1, kMaxInt);
  p.throw_on_failure = c.get_bool("throw_on_failure", p.throw_on_failure);
  return p;
}

const char* krylov_keys() { return kKrylovKeys; }

std::unique_ptr<Solver> build_solver(const Config& config, const SolverContext& context,
                                     const std::string& fallback_method) {
  const std::string method = config.get_string("method", fallback_method);
  const Entry* e = nullptr;
  {
    std::lock_guard<std::mutex> lock(registry().mutex);
    e = registry().find(method);
  }
  if (!e) {
    std::string list;
    for (const auto& info : registered_solvers()) list += (list.empty() ? "" : ", ") + info.name;
    config.fail("method", "unknown method '" + method + "' (" + list + ")");
  }
  return e->build(config, context);
}

std::unique_ptr<Solver> make_solver(const Config& config, const SolverContext& context,
                                    const std::string& fallback_method) {
  auto s = build_solver(config, context, fallback_method);
  config.check_all_used();
  return s;
}

void register_solver(const SolverInfo& info, SolverBuilder builder) {
  if (info.name.empty() || !builder) throw InputError("register_solver: a name and a builder are needed");
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  for (auto& e : r.entries)
    if (e.info.name == info.name) {
      e = {info, std::move(builder)};
      return;
    }
  r.entries.push_back({info, std::move(builder)});
}

std::vector<SolverInfo> registered_solvers() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<SolverInfo> out;
  for (const auto& e : r.entries) out.push_back(e.info);
  return out;
}

bool method_uses_levels(const std::string& method) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const Entry* e = r.find(method);
  return e && e->info.uses_levels;
}

bool method_needs_blocks(const std::string& method) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const Entry* e = r.find(method);
  return e && e->info.needs_blocks;
}

bool method_accepts_key(const std::string& method, const std::string& key) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const Entry* e = r.find(method);
  if (!e) return false;
  std::istringstream keys(e->info.keys);
  for (std::string k; keys >> k;)
    if (k == key) return true;
  return false;
}

}  // namespace pmg
