// The multigrid component's factory methods: cycles (pmg, mgpcg) and smoothers, each reading its
// own parameter struct's keys.
#include "pmg/cholmod/cholmod_solver.hpp"
#include "pmg/multigrid/chebyshev.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/sparse/saddle_point.hpp"
#include "pmg/multigrid/patch.hpp"
#include "pmg/multigrid/smoothers.hpp"

#include <cstdio>
#include <mutex>
#include <set>

namespace pmg::mg {

void GaussSeidelParams::visit(ParamVisitor& v) {
  v.integer("sweeps", sweeps, 1, 1000, "sweeps per pre-smoothing (forward) and post-smoothing (backward)");
  v.choice("ordering", ordering, {{"multicolor", Ordering::multicolor}, {"natural", Ordering::natural}},
           "block rows by colour (threaded) or in natural order (serial)");
}

void JacobiParams::visit(ParamVisitor& v) {
  v.integer("sweeps", sweeps, 1, 1000, "sweeps per pre- and post-smoothing");
  if (!l1) v.real("omega", omega, 1e-6, 2.0, "damping");
}

void RichardsonParams::visit(ParamVisitor& v) {
  v.integer("iterations", iterations, 1, 1000, "corrections per pre- and post-smoothing");
  v.real("omega", omega, 1e-6, 2.0, "damping of each correction");
}

void ChebyshevParams::visit(ParamVisitor& v) {
  v.integer("degree", degree, 1, 100, "polynomial degree: products with A per smoothing");
  v.choice("kind", kind,
           {{"first", ChebyshevKind::first}, {"fourth", ChebyshevKind::fourth},
            {"opt-fourth", ChebyshevKind::optimal_fourth}},
           "first: on [lower_fraction lmax, lmax]; fourth and opt-fourth (Lottes' optimised weights, "
           "degree <= 6): on [0, lmax], no lower bound");
  v.real("lower_fraction", lower_fraction, 1e-6, 1 - 1e-6, "first kind: the lower end of the damped interval");
  v.integer("power_iterations", power_iterations, 1, 1000,
            "steps of the set-up estimate of lmax of D^-1 A (power iterations, or Lanczos steps)");
  v.choice("estimate", lanczos, {{"power", false}, {"lanczos", true}},
           "lmax at set-up by power iteration, or by Lanczos (CG on A with D as preconditioner, as "
           "many steps as power_iterations): robust where the top of the spectrum is clustered");
  v.integer("update_iterations", update_iterations, 0, 1000,
            "per update(): 0 re-estimates lmax as at set-up; k runs k power iterations warm-started "
            "from the last power vector (15 from a fixed start where there is none)");
}

namespace {

/// The options of the cycle methods (pmg, mgpcg) beside their stopping rule.
struct CycleOptions {
  std::string cycle = "V";
  /// 0: 1 on the matrix-free route and for pmg, 2 for mgpcg on assembled levels (the seed's).
  int cycles = 0;
  std::string coarse_operator = "geometric";
  std::string restriction = "transpose";
  std::string op = "auto";
  std::string precision = "auto";
  int skip_levels = 0;
  std::string coarse_meshes = "auto";

  void visit(ParamVisitor& v) {
    v.choice("cycle", cycle, {"V", "W"}, "V- or W-cycle");
    v.integer("cycles", cycles, 0, 100,
              "cycles per application (0: 1 matrix-free, for pmg, for Chebyshev on vertex patches and for mgpcg's "
              "Chebyshev on user levels; 2 for mgpcg on an FEM scene's other assembled levels)");
    v.choice("coarse_operator", coarse_operator, {"geometric", "galerkin"},
             "lower levels: the provider's matrices (re-discretised) or Galerkin products R A P");
    v.choice("restriction", restriction, {"transpose", "interpolating"},
             "P transposed, or the provider's interpolating restriction (the seed's; not symmetric)");
    v.choice("operator", op, {"auto", "assembled", "matrix-free"},
             "auto: matrix-free where the levels offer operators, coarse_operator is geometric and the "
             "smoother is Chebyshev (its keys only); assembled: the level matrices");
    v.choice("precision", precision, {"auto", "double", "single"},
             "single: the matrix-free levels above the lowest (operators, Chebyshev smoothing, transfers) "
             "in float inside the cycle; the lowest level, the outer iteration and its residuals in double; "
             "auto: single where the levels allow it (matrix-free, Chebyshev, no components held on their "
             "own), else double");
    v.integer("skip_levels", skip_levels, 0, 100,
              "levels left out below the lowest one used: 1 on an FEM scene's degree hierarchy makes degree 2 the "
              "factorised lowest level (p >= 3), which does not lock for thin parts and nearly incompressible "
              "material as degree 1 does");
    const std::string coarse_meshes_help =
             "on: where the mesh was made by uniform refinement (a scene's mesh.refine, --refine k), the lowest "
             "level is solved by a cycle of its own over the linear spaces of the coarser meshes (Galerkin "
             "products, the smoother's keys), with lowest_level on the coarsest mesh; auto: on for mgpcg where "
             "the linear level has " + std::to_string(kAmgCoarseMeshUnknowns) + " unknowns or more; off: "
             "lowest_level on the linear level itself";
    v.choice("coarse_meshes", coarse_meshes, {"auto", "on", "off"}, coarse_meshes_help.c_str());
    v.solver("smoother", "chebyshev",
             "one per level above the lowest. Unset: chebyshev with kind opt-fourth and degree 3 (5 for "
             "mixed-minres and mixed-gmres; not the chebyshev method's own defaults) on the matrix-free route and for mgpcg on user levels (there with "
             "estimate lanczos); gauss-seidel, 2 sweeps, on the assembled route of an FEM hierarchy and for pmg "
             "on user levels");
    const std::string lowest_help =
        "the lowest level's solver; auto: for mgpcg CHOLMOD below " + std::to_string(kAmgLowestLevelUnknowns) +
        " unknowns (" + std::to_string(kAmgCoarseMeshUnknowns) + " on the coarsest of coarse_meshes), BoomerAMG "
        "(relax_type 16; one V-cycle, " + std::to_string(kAmgCoarseMeshCycles) +
        " on the coarsest of coarse_meshes) from there; CHOLMOD for pmg or when lowest_level "
        "keys are given (cg and boomeramg-pcg: tol 0.1, max_iterations 500, no throw; mgpcg then flexible)";
    v.solver("lowest_level", "auto", lowest_help.c_str());
  }
};

/// A smoother: a Smoother method, or any other solver used as Richardson's preconditioner.
std::unique_ptr<Smoother> build_smoother(const Config& c, const SolverContext& ctx) {
  std::unique_ptr<Solver> s = build_solver(c, ctx, "gauss-seidel");
  if (auto* sm = dynamic_cast<Smoother*>(s.get())) {
    s.release();
    return std::unique_ptr<Smoother>(sm);
  }
  return std::make_unique<Richardson>(std::move(s));
}

/// The lowest level's unknowns: from its node coordinates where the provider knows them (before
/// any assembly), else from its matrix.
index_t lowest_level_unknowns(const LevelProvider& levels, const std::vector<double>& xyz) {
  if (!xyz.empty()) return static_cast<index_t>(xyz.size());
  return levels.has_matrix(0) ? levels.matrix(0).rows() : 0;
}

}  // namespace

std::string choose_lowest_level(index_t unknowns, index_t amg_from) {
  bool amg = false;
  for (const SolverInfo& s : registered_solvers()) amg = amg || s.name == "boomeramg";
  return amg && unknowns >= amg_from ? "boomeramg" : kDefaultDirectMethod;
}

void set_amg_lowest_level_defaults(Config& lc) {
  // Measured on the quadratic cube's linear level (docs/scaling.md): BoomerAMG's own defaults with
  // Chebyshev relaxation (threaded, 40 ms against 59 ms per V-cycle at 1.1M fine unknowns) and
  // the same iterations; nodal coarsening with rigid-body interpolation vectors took 15-17
  // iterations instead of 19-21 but cost more per cycle and set-up, no level of aggressive
  // coarsening 11-16 iterations at twice the cost per cycle.
  lc.set_default("relax_type", "16");
}

namespace {

/// skip_levels: a view of the given levels from level skip_levels up (nullptr when none are
/// skipped); ctx.levels is set to the levels the cycle runs on.
std::shared_ptr<const LevelProvider> skip_view(const Config& c, const CycleOptions& o, SolverContext& ctx) {
  if (o.skip_levels <= 0) return nullptr;
  if (o.skip_levels > ctx.levels->num_levels() - 2)
    c.fail("skip_levels", "skip_levels=" + std::to_string(o.skip_levels) + " leaves fewer than two of the " +
                              std::to_string(ctx.levels->num_levels()) +
                              " levels (a degree-p BB hierarchy has p levels; skip_levels=1 needs p >= 3)");
  auto view = std::make_shared<LevelsFrom>(*ctx.levels, o.skip_levels);
  ctx.levels = view.get();
  return view;
}

/// What the smoother keys say: Chebyshev (named, or given only Chebyshev's keys, or none), and its
/// preconditioner M (block-jacobi unless smoother.preconditioner names another).
struct SmootherKind {
  bool chebyshev = true;  ///< Chebyshev in D⁻¹A (M = block-jacobi)
  bool patch = false;     ///< Chebyshev in M⁻¹A with M = patch (additive Schwarz on vertex stars)
};

SmootherKind smoother_kind(Config& sc) {
  // A smoother given a preconditioner (a plain "preconditioner=patch" becomes preconditioner.method)
  // and no method is Chebyshev, the smoother whose M it is.
  (void)sc.child("preconditioner");
  const bool has_preconditioner = sc.has_child("preconditioner");
  if (has_preconditioner) sc.set_default("method", "chebyshev");
  const std::string preconditioner =
      has_preconditioner ? sc.child("preconditioner").get_string("method", "block-jacobi") : "block-jacobi";
  SmootherKind k;
  if (sc.has("method")) {
    const std::string method = sc.get_string("method", "");
    k.chebyshev = method == "chebyshev";
    if (has_preconditioner && !k.chebyshev)
      sc.fail("preconditioner", "the smoother " + method +
                                    " takes no preconditioner (only chebyshev does: Chebyshev in M^-1 A); "
                                    "remove the key or use smoother=chebyshev");
  } else {
    std::set<std::string> keys;
    for (const auto& key : list_params<ChebyshevParams>()) keys.insert(key.key);
    for (const auto& [key, value] : sc.items())
      if (!keys.count(key.substr(sc.full_key("").size()))) k.chebyshev = false;
  }
  // Chebyshev in M⁻¹A with patch solves reads the level matrices' entries: the assembled route,
  // with the optimised fourth kind of degree 3 unless keys say otherwise (it needs no lower bound).
  // With M = block-jacobi it is the matrix-free route's own smoother.
  k.patch = k.chebyshev && preconditioner == "patch";
  if (preconditioner != "block-jacobi") k.chebyshev = false;
  if (k.patch) {
    sc.set_default("kind", "opt-fourth");
    sc.set_default("degree", "3");
  }
  return k;
}

/// Nearly incompressible material, stationary pmg, nothing said of the smoother: Chebyshev on
/// vertex patches, the measured faster route from kPatchLameRatio on (docs/robustness.md).
void choose_patches(Config& sc, const CycleOptions& o, const LevelProvider& levels, bool mgpcg, MultigridParams& p) {
  // (λ/μ at ν = 0.495 rounds to 98.999...: compared with a relative margin.)
  const double lame = levels.lame_ratio();
  if (!mgpcg && lame >= kPatchLameRatio * (1 - 1e-9) && sc.items().empty() && o.op == "auto" &&
      o.coarse_operator == "geometric" && o.precision != "single" && levels.vertex_patches(levels.num_levels() - 1)) {
    sc.set("preconditioner.method", "patch");
    char why[160];
    std::snprintf(why, sizeof why, "vertex patches: lambda/mu = %.3g >= %.3g, where point smoothing degrades",
                  lame, kPatchLameRatio);
    p.smoother_choice = why;
  }
}

/// The route (matrix-free or assembled), cycles per application and precision, with the smoother
/// defaults each route brings; refuses single precision off the matrix-free route.
void choose_route(const Config& c, Config& sc, const CycleOptions& o, const LevelProvider& levels, bool mgpcg,
                  MultigridParams& p) {
  p.matrix_free = o.op == "matrix-free";
  const SmootherKind kind = smoother_kind(sc);
  // A FEM code's own levels (matrices only: no matrix-free operators to offer): MGPCG defaults to
  // one cycle of the optimised fourth-kind Chebyshev of degree 3, measured 2.1-2.3x faster than
  // two cycles of block Gauss–Seidel on the bunny, degrees 2 and 3 (docs/other-fem-codes.md),
  // with λmax from Lanczos: any user's matrices, and 15 power steps underestimated a diffusion
  // hierarchy's (examples/python/user_levels.py) past the 10% margin.
  // Stationary PMG keeps Gauss–Seidel, which measured faster there. FEM scenes' assembled route
  // (operator=assembled) stays the chapter's Gauss–Seidel.
  const bool user_chebyshev = mgpcg && !levels.offers_matrix_free() && kind.chebyshev;
  if (user_chebyshev) {
    sc.set_default("method", "chebyshev");
    sc.set_default("kind", "opt-fourth");
    sc.set_default("degree", "3");
    sc.set_default("estimate", "lanczos");
  }
  if (o.op == "auto") {
    // Matrix-free where the levels offer operators and nothing asks for matrices: geometric lower
    // levels, and no smoother chosen other than Chebyshev (Gauss–Seidel's keys, say, keep the
    // assembled route the configuration was written for).
    p.matrix_free = levels.offers_matrix_free() && p.coarse_operator == CoarseOperator::geometric && kind.chebyshev;
    // Said in the solver's printed options: the route taken is part of what was run.
    if (p.matrix_free) Config(c).set("operator", "matrix-free");
  }
  p.cycles = o.cycles > 0 ? o.cycles : (mgpcg && !p.matrix_free && !user_chebyshev && !kind.patch ? 2 : 1);
  p.single_precision = o.precision == "single" || (o.precision == "auto" && p.matrix_free);
  p.single_where_possible = o.precision == "auto";
  if (p.single_precision && !p.matrix_free)
    c.fail("precision", "single precision runs the matrix-free levels in float: it needs operator=matrix-free "
                        "(levels with matrix-free operators, Chebyshev smoothing)");
}

/// The matrix-free route's checks and smoother defaults (Chebyshev of `degree`), and what single
/// precision needs of the smoother.
void check_matrix_free_route(const Config& c, Config& sc, const LevelProvider& levels, const MultigridParams& p,
                             int degree) {
  if (p.matrix_free) {
    if (p.coarse_operator == CoarseOperator::galerkin)
      c.fail("operator", "matrix-free levels need coarse_operator=geometric (Galerkin products are matrices)");
    // Asked without building them (an FEM hierarchy builds its operators when the cycle is set
    // up); a provider that does not say so is asked for the operators themselves.
    if (!levels.offers_matrix_free())
      for (int l = 1; l < levels.num_levels(); ++l)
        if (!levels.matrix_free_operator(l))
          c.fail("operator", "matrix-free needs levels with matrix-free operators (an FEM scene's degree "
                             "hierarchy has them for degree >= 2); these levels have none");
    // Gauss–Seidel needs the matrix's entries; Chebyshev needs only products and the diagonal. Its
    // eigenvalue estimate: 10 Lanczos steps at set-up (within 5% of λmax on the elasticity levels
    // measured, where 15 power iterations were up to 12% low: docs/scaling.md), refreshed per
    // update by one power iteration warm-started from the last. The optimised fourth kind (degree
    // 3, or `degree` for the mixed solvers) needs no lower bound (docs/performance.md).
    sc.set_default("method", "chebyshev");
    if (sc.get_string("method", "chebyshev") == "chebyshev") {
      sc.set_default("kind", "opt-fourth");
      sc.set_default("degree", std::to_string(degree));
      sc.set_default("estimate", "lanczos");
      if (sc.get_string("estimate", "lanczos") == "lanczos") sc.set_default("power_iterations", "10");
      sc.set_default("update_iterations", "1");
    }
  }
  if (p.single_precision && !p.single_where_possible && sc.get_string("method", "chebyshev") != "chebyshev")
    c.fail("precision", "single precision smooths with Chebyshev only (the float cycle has no " +
                            sc.get_string("method", "") + ")");
}

/// The lowest level's solver keys: `auto` resolved and written back (so the printed options say
/// what ran), and the defaults of the method chosen.
Config lowest_level_config(const Config& c, const LevelProvider& levels, bool mgpcg, const std::vector<double>& xyz,
                           int amg_cycles, index_t amg_from) {
  Config lc = c.child("lowest_level");
  // auto: for MGPCG by the lowest level's size, from the measured break-even (docs/scaling.md);
  // CHOLMOD for stationary PMG (one inexact V-cycle slows a stationary cycle far more: 990
  // cycles instead of 12 on the slender bar of docs/performance.md) and wherever lowest-level keys
  // are given without a method (they were CHOLMOD's before auto).
  if (lc.get_string("method", "auto") == "auto") {
    bool keys = false;
    for (const auto& kv : lc.items()) keys = keys || kv.first != lc.full_key("method");
    const std::string chosen =
        mgpcg && !keys ? choose_lowest_level(lowest_level_unknowns(levels, xyz), amg_from) : kDefaultDirectMethod;
    lc.set("method", chosen);
  }
  if (lc.get_string("method", "") == "boomeramg") {
    set_amg_lowest_level_defaults(lc);
    if (amg_cycles > 1) lc.set_default("cycles", std::to_string(amg_cycles));
  }
  // The linear level solved by CG to a loose tolerance: a usable correction even when the inner
  // solve stops early (the outer iteration judges it); only a broken one is an error.
  const std::string lm = lc.get_string("method", kDefaultDirectMethod);
  // The lowest level's factorisation and solves run between the cycle's OpenMP kernels: serial
  // BLAS in the solves, threaded factorisations (the cholmod keys blas_threads, factor_threads).
  if (lm == "cholmod") {
    lc.set_default("blas_threads", "1");
    lc.set_default("factor_threads", "0");
  }
  if (lm == "cg" || lm == "boomeramg-pcg") {
    lc.set_default("tol", "0.1");
    lc.set_default("max_iterations", "500");
    lc.set_default("throw_on_failure", "false");
  }
  return lc;
}

/// One smoother per level of ctx.levels above the lowest, each built from the same keys.
std::vector<std::unique_ptr<Smoother>> build_smoothers(const Config& sc, const SolverContext& ctx) {
  std::vector<std::unique_ptr<Smoother>> smoothers;
  for (int l = 1; l < ctx.levels->num_levels(); ++l) {
    SolverContext level_ctx = ctx;
    level_ctx.level = l;
    smoothers.push_back(build_smoother(sc, level_ctx));
  }
  return smoothers;
}

/// The lowest_level keys' solver on level 0 of ctx.levels, set up as a system of its own: xyz, its
/// nodes' coordinates (ctx.levels->node_coordinates(0); empty where the levels do not know them),
/// not the finest level's; `auto` takes AMG from amg_from unknowns, BoomerAMG runs amg_cycles
/// V-cycles per application unless its keys say otherwise.
std::unique_ptr<Solver> build_level_solver(const Config& c, const SolverContext& ctx, bool mgpcg,
                                           const std::vector<double>& xyz, int amg_cycles = 1,
                                           index_t amg_from = kAmgLowestLevelUnknowns) {
  const Config lc = lowest_level_config(c, *ctx.levels, mgpcg, xyz, amg_cycles, amg_from);
  SolverContext lowest_ctx = ctx;
  lowest_ctx.coordinates = xyz.empty() ? nullptr : &xyz;
  return build_solver(lc, lowest_ctx, kDefaultDirectMethod);
}

/// The lowest level's solver: lowest_level on the levels' level 0, or (coarse_meshes) one cycle
/// over the coarser meshes' linear levels under it — Galerkin products, the smoother keys' smoothers,
/// lowest_level on the coarsest mesh — the geometric h-levels a refined mesh brings, so that an AMG
/// or a factorisation sees the coarse mesh only.
std::unique_ptr<Solver> build_lowest(const Config& c, const CycleOptions& o, const SolverContext& ctx,
                                     const Config& sc, bool mgpcg, const MultigridParams& p) {
  const LevelProvider& levels = *ctx.levels;
  const std::shared_ptr<const LevelProvider> below = levels.levels_below();
  const std::vector<double> xyz = levels.node_coordinates(0);
  bool use = o.coarse_meshes == "on";
  if (use && !below)
    c.fail("coarse_meshes", "coarse_meshes=on needs levels with coarser meshes under the linear level: an FEM "
                            "scene whose mesh was made by uniform refinement (mesh.refine, --refine k), used "
                            "without skip_levels");
  // The inner cycle's top level is the provider's linear matrix: with Galerkin coarse operators the
  // outer cycle's lowest level is a product instead (and the provider's is not assembled).
  if (use && p.coarse_operator == CoarseOperator::galerkin)
    c.fail("coarse_meshes", "coarse_meshes=on needs coarse_operator=geometric (the coarser meshes sit under the "
                            "hierarchy's own linear level, not under a Galerkin product)");
  if (o.coarse_meshes == "auto")
    use = below && mgpcg && p.coarse_operator == CoarseOperator::geometric &&
          lowest_level_unknowns(levels, xyz) >= kAmgCoarseMeshUnknowns;
  if (!use) return build_level_solver(c, ctx, mgpcg, xyz);
  SolverContext h = ctx;
  h.levels = below.get();
  MultigridParams hp;
  hp.gamma = p.gamma;
  hp.coarse_operator = CoarseOperator::galerkin;
  hp.cycles = 1;
  auto smoothers = build_smoothers(sc, h);
  auto factory = [&](int l) { return std::move(smoothers[l - 1]); };
  return std::make_unique<MultigridCycle>(
      below, hp, factory,
      build_level_solver(c, h, mgpcg, below->node_coordinates(0), kAmgCoarseMeshCycles, kAmgCoarseMeshUnknowns));
}

/// The matrix-free route's default Chebyshev degree in the mixed solvers' cycle (register_all).
constexpr int kMixedChebyshevDegree = 5;

/// A multigrid cycle from the CycleOptions keys; `mgpcg`: the defaults of a preconditioner;
/// `chebyshev_degree`: the matrix-free route's default smoother degree.
std::unique_ptr<MultigridCycle> build_cycle(const Config& c, const SolverContext& given, bool mgpcg,
                                            const KrylovParams& iteration, int chebyshev_degree = 3) {
  if (!given.levels || given.levels->num_levels() < 2)
    c.fail("method", "multigrid needs at least two levels: an FEM scene of degree >= 2, or level "
                     "matrices with prolongations");
  const CycleOptions o = read_params<CycleOptions>(c);
  SolverContext ctx = given;
  const std::shared_ptr<const LevelProvider> view = skip_view(c, o, ctx);
  const LevelProvider& levels = *ctx.levels;
  MultigridParams p;
  p.gamma = o.cycle == "W" ? 2 : 1;
  p.coarse_operator = o.coarse_operator == "galerkin" ? CoarseOperator::galerkin : CoarseOperator::geometric;
  p.interpolating_restriction = o.restriction == "interpolating";
  p.iteration = iteration;
  Config sc = c.child("smoother");
  // Additive Schwarz on overlapping patches has λmax(M⁻¹A) up to the patches' overlap: undamped
  // Richardson (what a non-smoother becomes) diverges, so patch is only a preconditioner here.
  if (sc.get_string("method", "") == "patch")
    c.fail("smoother", "patch is a preconditioner, not a smoother of its own (x += M r diverges on overlapping "
                       "patches): use smoother.preconditioner=patch (Chebyshev in M^-1 A)");
  choose_patches(sc, o, levels, mgpcg, p);
  choose_route(c, sc, o, levels, mgpcg, p);
  // CG needs a symmetric cycle; refused here, before an inner lowest-level solve would make the
  // outer iteration flexible and hide it.
  if (mgpcg && p.interpolating_restriction)
    c.fail("restriction", "mgpcg needs restriction=transpose: CG needs a symmetric cycle, and the "
                          "interpolating restriction is not the prolongation's transpose (use pmg)");
  check_matrix_free_route(c, sc, levels, p, chebyshev_degree);
  auto lowest = build_lowest(c, o, ctx, sc, mgpcg, p);
  // One smoother per level, built from the same options (read once per level: same keys).
  auto smoothers = build_smoothers(sc, ctx);
  auto factory = [&](int l) { return std::move(smoothers[l - 1]); };
  if (view) return std::make_unique<MultigridCycle>(view, p, factory, std::move(lowest));
  return std::make_unique<MultigridCycle>(levels, p, factory, std::move(lowest));
}

void register_all() {
  cholmod::register_solvers();  // the cycles' default lowest level
  const std::vector<KeyInfo> cycle_keys = list_params<CycleOptions>();
  register_builtin_solver({"pmg", "stationary multigrid: one cycle per iteration", krylov_keys() + cycle_keys, true, true,
                   "multigrid"},
                  [](const Config& c, const SolverContext& ctx) { return build_cycle(c, ctx, false, read_krylov(c)); });
  register_builtin_solver({"mgpcg", "CG preconditioned by multigrid cycles", krylov_keys() + cycle_keys, true, true,
                   "multigrid"},
                  [](const Config& c, const SolverContext& ctx) {
                    const KrylovParams k = read_krylov(c);
                    return std::make_unique<Cg>(k, build_cycle(c, ctx, true, KrylovParams{}));
                  });
  // The saddle-point methods of mixed elasticity: mgpcg's cycle on the displacement block, with
  // Chebyshev of degree 5 on the matrix-free route. Each Krylov iteration here costs about twice the
  // cycle's smoothing (orthogonalisation, B and Bᵀ, the pressure solve, the product with A), so a
  // stronger cycle pays: degree 5 took mixed-gmres on Homer P3 at ν = 0.499 from 41 to 29
  // iterations to 1e-6 and 1.2x less time, the thin plate's 50 steps from 8,817 to 5,805 iterations
  // (1.5x less time), and mixed-minres from 179 to 127 (docs/robustness.md). mgpcg itself keeps
  // degree 3: 4 and 5 measured no faster there.
  auto mixed = [](MixedKrylov::Kind kind) {
    return [kind](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
      const std::string me = kind == MixedKrylov::Kind::minres ? "mixed-minres" : "mixed-gmres";
      if (!ctx.saddle_point)
        c.fail("method", me + " solves a mixed (displacement-pressure) system: use it with formulation=mixed");
      const KrylovParams k = read_krylov(c);
      const MixedKrylovParams mp = read_params<MixedKrylovParams>(c);
      const GmresParams g = kind == MixedKrylov::Kind::gmres ? read_params<GmresParams>(c) : GmresParams{};
      return std::make_unique<MixedKrylov>(kind, k, build_cycle(c, ctx, true, KrylovParams{}, kMixedChebyshevDegree),
                                           *ctx.saddle_point, mp, g);
    };
  };
  register_builtin_solver({"mixed-minres",
                   "MINRES on a displacement-pressure saddle point, preconditioned by mgpcg's cycle on the "
                   "displacement block and Chebyshev on the scaled pressure mass (mixed elasticity)",
                   krylov_keys() + cycle_keys + list_params<MixedKrylovParams>(), true, true, "multigrid"},
                  mixed(MixedKrylov::Kind::minres));
  register_builtin_solver({"mixed-gmres",
                   "GMRES on a displacement-pressure saddle point with the block-triangular preconditioner: "
                   "Chebyshev on the scaled pressure mass, then mgpcg's cycle on the displacement block (mixed "
                   "elasticity)",
                   krylov_keys() + cycle_keys + list_params<MixedKrylovParams>() + list_params<GmresParams>(), true,
                   true, "multigrid"},
                  mixed(MixedKrylov::Kind::gmres));
  auto gauss_seidel = [](bool pointwise) {
    return [pointwise](const Config& c, const SolverContext&) {
      GaussSeidelParams p;
      p.pointwise = pointwise;
      return std::make_unique<BlockGaussSeidel>(read_params(c, p));
    };
  };
  register_builtin_solver({"gauss-seidel", "3x3-block Gauss-Seidel (forward pre-, backward post-smoothing)",
                   list_params<GaussSeidelParams>(), false, true, "multigrid"},
                  gauss_seidel(false));
  register_builtin_solver({"point-gauss-seidel", "scalar Gauss-Seidel inside 3x3 block rows",
                   list_params<GaussSeidelParams>(), false, true, "multigrid"},
                  gauss_seidel(true));
  ParamLister chebyshev_preconditioner;
  chebyshev_preconditioner.solver("preconditioner", "block-jacobi",
                                  "M of the polynomial in M^-1 A: block-jacobi (the 3x3 diagonal blocks D) or patch "
                                  "(additive Schwarz on the levels' vertex stars: nearly incompressible materials, "
                                  "thin parts; assembled levels)");
  register_builtin_solver({"chebyshev", "Chebyshev polynomial on D^-1 A (3x3 blocks D) or M^-1 A",
                   list_params<ChebyshevParams>() + chebyshev_preconditioner.keys(), false, true, "multigrid"},
                  [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                    const ChebyshevParams p = read_params<ChebyshevParams>(c);
                    const Config pc = c.child("preconditioner");
                    const std::string m = pc.get_string("method", "block-jacobi");
                    if (m == "block-jacobi") return std::make_unique<Chebyshev>(p);
                    // M must be symmetric positive definite and linear (Chebyshev, and CG over
                    // it, rely on it): the vertex patches are; other solvers are not accepted.
                    if (m != "patch")
                      pc.fail("method", "Chebyshev's preconditioner is block-jacobi or patch, not '" + m + "'");
                    return std::make_unique<Chebyshev>(p, build_solver(pc, ctx, "block-jacobi"));
                  });
  register_builtin_solver({"patch", "additive Schwarz on the levels' vertex patches (open vertex stars), dense "
                                    "Cholesky per patch: Chebyshev's or Richardson's M",
                   list_params<PatchParams>(), true, true, "multigrid"},
                  [](const Config& c, const SolverContext& ctx) {
                    if (!ctx.levels)
                      c.fail("method", "patch needs levels that define vertex patches (an FEM scene of degree >= 2)");
                    const int level = ctx.level >= 0 ? ctx.level : ctx.levels->num_levels() - 1;
                    const std::vector<std::vector<index_t>>* patches = ctx.levels->vertex_patches(level);
                    if (!patches)
                      c.fail("method", "patch: " + ctx.levels->level_name(level) +
                                           " defines no vertex patches (an FEM scene's levels of degree >= 2 do)");
                    return std::make_unique<PatchSchwarz>(*patches, read_params<PatchParams>(c));
                  });
  register_builtin_solver({"damped-jacobi", "damped 3x3 block Jacobi x += omega D^-1 (b - A x)",
                   list_params<JacobiParams>(), false, true, "multigrid"},
                  [](const Config& c, const SolverContext&) {
                    return std::make_unique<BlockJacobi>(read_params<JacobiParams>(c));
                  });
  JacobiParams l1;
  l1.sweeps = 2;
  l1.omega = 1.0;
  l1.l1 = true;
  register_builtin_solver({"l1-jacobi", "l1 block Jacobi x += (D + l1 row sums)^-1 (b - A x): no damping to tune",
                   list_params(l1), false, true, "multigrid"},
                  [l1](const Config& c, const SolverContext&) {
                    return std::make_unique<BlockJacobi>(read_params(c, l1));
                  });
  ParamLister preconditioner;
  preconditioner.solver("preconditioner", "block-jacobi", "the solver M");
  register_builtin_solver({"richardson", "x += omega M (b - A x) with any solver M",
                   list_params<RichardsonParams>() + preconditioner.keys(), false, false, "multigrid"},
                  [](const Config& c, const SolverContext& ctx) {
                    const RichardsonParams p = read_params<RichardsonParams>(c);
                    return std::make_unique<Richardson>(build_solver(c.child("preconditioner"), ctx, "block-jacobi"), p);
                  });
}

}  // namespace

void register_solvers() {
  static std::once_flag once;
  std::call_once(once, register_all);
}

std::unique_ptr<MultigridCycle> make_cycle(const Config& config, const SolverContext& context) {
  register_solvers();  // smoothers and the lowest level's method
  if (config.get_string("method", "pmg") != "pmg")
    config.fail("method", "make_cycle builds the stationary pmg method's cycle only");
  auto cycle = build_cycle(config, context, false, read_krylov(config));
  config.check_all_used();
  return cycle;
}

}  // namespace pmg::mg
