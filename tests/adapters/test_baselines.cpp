// The baselines' adapters (BoomerAMG with every elasticity option, PETSc's GAMG, MUMPS and CHOLMOD)
// against our CHOLMOD on a small SPD elasticity system, and their bad options named in errors.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/hypre/boomeramg.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/petsc/petsc.hpp"
#include "pmg/cholmod/cholmod_solver.hpp"

#include <catch2/catch.hpp>

#include <cctype>

using namespace pmg;
using namespace pmg::fem;

namespace {
/// A quadratic bar clamped at x = 0 under gravity, with its free nodes' coordinates.
struct Bar {
  TetMesh mesh = box_mesh_24(6, 2, 2, 1.0, 0.3, 0.3);
  DegreeHierarchy h{mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }};
  Vector b, x_ref;
  std::vector<double> xyz;
  Bar() {
    h.assemble(nullptr);
    b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
    const Vector free = h.finest().free_positions();
    xyz.assign(free.data(), free.data() + free.size());
    CholmodSolver chol;
    chol.setup(A());
    chol.apply(b, x_ref);
  }
  const Bcsr& A() const { return h.matrix(1); }
  std::unique_ptr<Solver> build(std::vector<std::string> options, bool coordinates = true) const {
    SolverContext ctx;
    ctx.coordinates = coordinates ? &xyz : nullptr;
    auto s = make_solver(Config::from_pairs(options, "test"), ctx);
    s->setup(A());
    return s;
  }
  /// Relative error of a solve from zero against CHOLMOD's solution.
  double error(const Solver& s, SolveResult* result = nullptr) const {
    Vector x = Vector::Zero(b.size());
    const SolveResult r = s.solve(b, x);
    if (result) *result = r;
    return (x - x_ref).norm() / x_ref.norm();
  }
};
}  // namespace

TEST_CASE("BoomerAMG-PCG with each elasticity option reaches CHOLMOD's solution", "[multigrid][baselines]") {
  Bar bar;
  const std::vector<std::vector<std::string>> settings = {
      {},
      {"nodal=4"},
      {"nodal=4", "interp_vectors=rigid", "p_max=0"},
      {"nodal=4", "interp_vectors=rigid", "interp_vec_variant=1"},
      {"coarsen_type=6", "interp_type=0", "p_max=0"},
      {"coarsen_type=8", "strong_threshold=0.25", "trunc_factor=0.1"},
      {"relax_type=6", "relax_order=1", "sweeps=2", "relax_coarse=8"},
      {"agg_levels=1", "agg_interp_type=4", "max_levels=3", "max_coarse_size=50"},
  };
  for (auto opts : settings) {
    opts.insert(opts.begin(), "method=boomeramg-pcg");
    opts.push_back("tol=1e-10");
    INFO(Config::from_pairs(opts, "test").to_string());
    const auto s = bar.build(opts);
    SolveResult r;
    CHECK(bar.error(*s, &r) < 1e-7);
    CHECK(r.status == SolveStatus::converged);
    // The settings and the hierarchy are reported.
    const std::string d = s->describe();
    CHECK(d.find("levels, grid complexity") != std::string::npos);
    for (size_t k = 1; k + 1 < opts.size(); ++k) {
      const std::string kv = opts[k].find("interp_vectors") == 0 ? "interp_vectors=rigid" : opts[k];
      CHECK(d.find(kv) != std::string::npos);
    }
  }
  // max_levels=3 is obeyed
  const auto capped = bar.build({"method=boomeramg", "max_levels=3"});
  CHECK(dynamic_cast<const mg::BoomerAMG&>(*capped).num_levels() <= 3);
  CHECK(dynamic_cast<const mg::BoomerAMG&>(*capped).operator_complexity() >= 1.0);
}

TEST_CASE("BoomerAMG's bad options are named", "[multigrid][baselines]") {
  Bar bar;
  auto message = [&](std::vector<std::string> opts, bool coordinates = true) {
    try {
      bar.build(opts, coordinates);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(message({"method=boomeramg-pcg", "relax_order=2"}), Catch::Contains("relax_order"));
  CHECK_THAT(message({"method=boomeramg-pcg", "interp_vectors=all"}), Catch::Contains("interp_vectors"));
  CHECK_THAT(message({"method=boomeramg-pcg", "nodal=4", "interp_vectors=rigid"}, false),
             Catch::Contains("interp_vectors") && Catch::Contains("coordinates"));
  CHECK_THAT(message({"method=boomeramg-pcg", "interp_vectors=rigid"}), Catch::Contains("nodal coarsening"));
  // hypre 2.26 (Debian 12's) fails to set up GM-2 interpolation vectors with truncated
  // interpolation (p_max=4, no aggressive level) on this bar: the error says so, with the way out.
  CHECK_THROWS_WITH(bar.build({"method=boomeramg-pcg", "nodal=4", "interp_vectors=rigid", "p_max=4", "agg_levels=0"}),
                    Catch::Contains("interp_vec_variant=1") && Catch::Contains("p_max=0"));
  CHECK_THAT(message({"method=boomeramg-pcg", "coarsening=10"}), Catch::Contains("coarsening"));
}

TEST_CASE("CHOLMOD reports its ordering and factor", "[multigrid][baselines]") {
  Bar bar;
  CholmodSolver chol;
  chol.setup(bar.A());
  CHECK(!chol.ordering().empty());
  CHECK_THAT(chol.describe(), Catch::Contains("ordering " + chol.ordering()) && Catch::Contains("factor nonzeros"));
  CHECK(chol.factor_nnz() > bar.A().num_blocks() * 9 / 2.0);
  CHECK(chol.ordering() == "METIS");  // the default
  for (const char* ordering : {"amd", "metis", "nesdis"}) {
    const auto s = bar.build({"method=cholmod", std::string("ordering=") + ordering});
    CHECK(bar.error(*s) < 1e-10);
    std::string upper = ordering;
    for (char& ch : upper) ch = static_cast<char>(std::toupper(ch));
    CHECK_THAT(s->describe(), Catch::Contains("ordering " + upper));
  }
  CHECK_THROWS_WITH(bar.build({"method=cholmod", "ordering=rcm"}), Catch::Contains("ordering"));
}

TEST_CASE("PETSc's GAMG, MUMPS and CHOLMOD reach our CHOLMOD's solution", "[multigrid][baselines][petsc]") {
  Bar bar;
  if (!mg::petsc_available()) {
    // Without PETSc the methods exist and say what is missing.
    CHECK_THROWS_WITH(bar.build({"method=gamg-pcg"}), Catch::Contains("libpetsc-real-dev"));
    WARN("PETSc is not built in: only its error message was checked");
    return;
  }
  for (const char* m : {"mumps", "petsc-cholmod"}) {
    INFO(m);
    const auto s = bar.build({std::string("method=") + m});
    CHECK(bar.error(*s) < 1e-10);
    CHECK_THAT(s->describe(), Catch::Contains("factor nonzeros"));
  }
  SolveResult rigid, plain;
  CHECK(bar.error(*bar.build({"method=gamg-pcg", "tol=1e-10"}), &rigid) < 1e-7);
  CHECK(bar.error(*bar.build({"method=gamg-pcg", "tol=1e-10", "near_null_space=none"}), &plain) < 1e-7);
  CHECK(rigid.status == SolveStatus::converged);
  CHECK(plain.status == SolveStatus::converged);
  CHECK(rigid.iterations <= plain.iterations);  // the rigid-body modes help smoothed aggregation
  const auto gamg = bar.build({"method=gamg", "options=-pc_gamg_threshold 0.02 -mg_levels_ksp_max_it 3"});
  CHECK_THAT(gamg->describe(), Catch::Contains("levels, grid complexity") &&
                                   Catch::Contains("-pc_gamg_threshold 0.02") &&
                                   Catch::Contains("rigid-body modes"));
  // GAMG is a fixed symmetric operator: it can precondition CG.
  const Vector u = Vector::Random(bar.b.size()), v = Vector::Random(bar.b.size());
  Vector Mu, Mv;
  gamg->apply(u, Mu);
  gamg->apply(v, Mv);
  CHECK(std::abs(Mu.dot(v) - u.dot(Mv)) <= 1e-8 * Mu.norm() * v.norm());
  // New values on the same pattern: update() refactors.
  auto chol = make_solver(Config::from_pairs({"method=mumps"}, "test"));
  Bcsr A = bar.A();
  chol->setup(A);
  for (double& v : A.values()) v *= 2;  // 2K: the solution halves
  chol->update();
  Vector x = Vector::Zero(bar.b.size());
  chol->solve(bar.b, x);
  CHECK((2 * x - bar.x_ref).norm() <= 1e-9 * bar.x_ref.norm());
}

TEST_CASE("PETSc's bad options and missing coordinates are named", "[multigrid][baselines][petsc]") {
  if (!mg::petsc_available()) return;
  Bar bar;
  CHECK_THROWS_WITH(bar.build({"method=gamg-pcg", "near_null_space=rigid"}, false),
                    Catch::Contains("near_null_space") && Catch::Contains("coordinates"));
  CHECK_THROWS_WITH(bar.build({"method=gamg-pcg", "near_null_space=modes"}), Catch::Contains("near_null_space"));
  CHECK_THROWS_WITH(bar.build({"method=gamg", "options=-pc_gamg_threshold abc"}),
                    Catch::Contains("PETSc") && Catch::Contains("abc"));
  CHECK_THROWS_WITH(bar.build({"method=mumps", "ordering=metis"}), Catch::Contains("ordering"));
  // Without coordinates, auto falls back to PETSc's default near-null space and says so.
  CHECK_THAT(bar.build({"method=gamg"}, false)->describe(), Catch::Contains("PETSc's default"));
}
