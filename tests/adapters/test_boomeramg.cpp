#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/simulation.hpp"
#include "pmg/hypre/boomeramg.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/user_levels.hpp"
#include "pmg/sparse/csr_view.hpp"
#include "pmg/sparse/generators.hpp"
#include "pmg/cholmod/cholmod_solver.hpp"

#include <catch2/catch.hpp>

#include <cstdio>

using namespace pmg;
using namespace pmg::fem;

namespace {
struct Bar {
  TetMesh mesh = box_mesh_24(10, 2, 2, 1.0, 0.2, 0.2);
  DegreeHierarchy h{mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }};
  Vector b;
  Bar() {
    h.assemble(nullptr);
    b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
  }
  /// A factory-built solver on the bar's levels, set up on the finest matrix.
  std::unique_ptr<Solver> build(std::vector<std::string> options) const {
    options.push_back("tol=1e-8");
    options.push_back("max_iterations=200");
    options.push_back("operator=assembled");  // the lowest levels compared under the assembled cycle
    SolverContext ctx;
    ctx.levels = &h;
    auto s = make_solver(Config::from_pairs(options, "test"), ctx);
    s->setup(h.matrix(1));
    return s;
  }
};
}  // namespace

TEST_CASE("BoomerAMG-preconditioned CG solves the quadratic bar (also on 2 MPI ranks)", "[multigrid][boomeramg]") {
  Bar bar;
  const Bcsr& A = bar.h.matrix(1);
  const mg::BoomerAMG amg(A, {});
  KrylovParams p;
  p.rel_tol = 1e-8;
  Vector x = Vector::Zero(bar.b.size());
  const SolveResult r = pcg(A, &amg, bar.b, x, p);
  CHECK(r.status == SolveStatus::converged);
  Vector x_cg = Vector::Zero(bar.b.size());
  const SolveResult plain = cg(A, bar.b, x_cg, p);
  CHECK(r.iterations < plain.iterations / 2);  // AMG at least halves the CG iterations
  CHECK((x - x_cg).norm() <= 1e-6 * x_cg.norm());
  if (mpi::rank() == 0)
    std::printf("BoomerAMG-PCG on %d rank(s): %d iterations (CG: %d)\n", mpi::size(), r.iterations,
                plain.iterations);
}

TEST_CASE("BoomerAMG as PMG's lowest-level solver", "[multigrid][boomeramg]") {
  Bar bar;
  Vector x = Vector::Zero(bar.b.size());
  // One AMG cycle is an inexact lowest-level solve: the PMG cycle still converges, more slowly.
  const SolveResult r = bar.build({"method=mgpcg", "lowest_level=boomeramg"})->solve(bar.b, x);
  CHECK(r.status == SolveStatus::converged);
}

TEST_CASE("BoomerAMG lowest levels: V-cycles keep the cycle symmetric for MGPCG, CG on top restores stationary PMG", "[multigrid][boomeramg]") {
  Bar bar;  // slender (10x2x2): its bending modes are what one AMG V-cycle contracts slowly
  const Bcsr& A = bar.h.matrix(1);
  Vector x_ref = Vector::Zero(bar.b.size());
  const SolveResult ref = bar.build({"method=pmg"})->solve(bar.b, x_ref);  // CHOLMOD on the linear level
  REQUIRE(ref.status == SolveStatus::converged);

  SECTION("fixed V-cycles: a symmetric cycle, MGPCG converges; more V-cycles, fewer iterations") {
    int previous = 1 << 30;
    for (int cycles : {1, 4}) {
      const auto cycle = bar.build({"method=pmg", "lowest_level=boomeramg",
                                    "lowest_level.cycles=" + std::to_string(cycles)});
      INFO(cycles << " AMG V-cycles per linear-level solve");
      const Vector u = Vector::Random(A.rows()), v = Vector::Random(A.rows());
      Vector Cu, Cv;
      cycle->apply(u, Cu);
      cycle->apply(v, Cv);
      CHECK(std::abs(Cu.dot(v) - u.dot(Cv)) <= 1e-10 * Cu.norm() * v.norm());
      Vector y = Vector::Zero(bar.b.size());
      const SolveResult r = bar.build({"method=mgpcg", "cycles=1", "lowest_level=boomeramg",
                                       "lowest_level.cycles=" + std::to_string(cycles)})
                                ->solve(bar.b, y);
      CHECK(r.status == SolveStatus::converged);
      CHECK((y - x_ref).norm() <= 1e-6 * x_ref.norm());
      CHECK(r.iterations < previous);
      previous = r.iterations;
    }
  }
  SECTION("CG to 1e-1 on the linear level: stationary PMG within two cycles of the exact lowest level") {
    const auto pmg = bar.build({"method=pmg", "lowest_level=boomeramg-pcg", "lowest_level.tol=0.1"});
    Vector x = Vector::Zero(bar.b.size());
    const SolveResult r = pmg->solve(bar.b, x);
    INFO("PMG cycles: " << r.iterations << " (CHOLMOD lowest level: " << ref.iterations << ")");
    CHECK(r.status == SolveStatus::converged);
    CHECK(r.iterations <= ref.iterations + 2);
    CHECK((x - x_ref).norm() <= 1e-6 * x_ref.norm());
    // The inner CG makes the cycle depend on its input: MGPCG on it is flexible CG, and converges
    // to the same solution.
    CHECK_FALSE(pmg->is_symmetric());
    const auto fcg = bar.build({"method=mgpcg", "lowest_level=boomeramg-pcg"});
    CHECK(fcg->name() == "flexible cg(multigrid (V-cycle))");
    Vector xf = Vector::Zero(bar.b.size());
    const SolveResult rf = fcg->solve(bar.b, xf);
    CHECK(rf.status == SolveStatus::converged);
    CHECK(rf.iterations <= ref.iterations + 4);
    CHECK((xf - x_ref).norm() <= 1e-6 * x_ref.norm());
    // update() (as after a time step's re-assembly) redoes the AMG set-up; on unchanged values
    // the refreshed cycle must behave exactly as the first one.
    pmg->update();
    Vector x2 = Vector::Zero(bar.b.size());
    CHECK(pmg->solve(bar.b, x2).iterations == r.iterations);
  }
  SECTION("a tolerance outside [0, 1) is refused, naming the key") {
    CHECK_THROWS_WITH(bar.build({"method=pmg", "lowest_level=boomeramg-pcg", "lowest_level.tol=1.5"}),
                      Catch::Contains("lowest_level.tol"));
    CHECK_THROWS_WITH(bar.build({"method=pmg", "lowest_level=boomeramg-pcg", "lowest_level.tol=nan"}),
                      Catch::Contains("lowest_level.tol"));
  }
}

TEST_CASE("BoomerAMG refuses a matrix with NaN", "[multigrid][boomeramg][errors]") {
  Csr A = Csr::from_triplets(3, 3, {{0, 0, 1.0}, {1, 1, std::nan("")}, {2, 2, 1.0}});
  CHECK_THROWS_WITH(mg::BoomerAMG(A, {}), Catch::Contains("NaN"));
}

TEST_CASE("BoomerAMG reads a Bcsr as its scalar copy, update() equals a new set-up, a row without diagonal is named",
          "[multigrid][boomeramg]") {
  Bar bar;
  Bcsr A = bar.h.matrix(1);
  const Csr scalar = A.to_csr();
  Vector x_block, x_scalar;
  const mg::BoomerAMG from_block(A, {}), from_scalar(scalar, {});
  from_block.apply(bar.b, x_block);
  from_scalar.apply(bar.b, x_scalar);
  REQUIRE(x_block.allFinite());
  CHECK(x_block == x_scalar);  // the same entries in the same order: the same hierarchy
  CHECK(from_block.describe() == from_scalar.describe());

  // New values on the same pattern (a stiffer material in part of the bar): update() rebuilds
  // hypre's matrix in place and gives what a new set-up on the new values gives.
  mg::BoomerAMG updated(A, {});
  for (offset_t k = 0; k < static_cast<offset_t>(A.values().size()); k += 2) A.values()[k] *= 3.0;
  updated.update();
  const mg::BoomerAMG fresh(A, {});
  Vector x_updated, x_fresh;
  updated.apply(bar.b, x_updated);
  fresh.apply(bar.b, x_fresh);
  CHECK(x_updated == x_fresh);
  CHECK_FALSE(x_updated == x_block);

  // hypre's relaxations divide by the diagonal: a structurally missing one is refused by row.
  const Csr no_diagonal = Csr::from_triplets(3, 3, {{0, 0, 2.0}, {1, 2, 1.0}, {2, 1, 1.0}, {2, 2, 2.0}});
  CHECK_THROWS_WITH(mg::BoomerAMG(no_diagonal, {}), Catch::Contains("row 1 has no diagonal entry"));
}

TEST_CASE("any solver composes with BoomerAMG: MGPCG on a BoomerAMG lowest level with Chebyshev smoothing",
          "[multigrid][boomeramg][factory]") {
  Bar bar;
  const Bcsr& A = bar.h.matrix(1);
  CholmodSolver chol;
  chol.setup(A);
  Vector x_ref;
  chol.apply(bar.b, x_ref);
  Vector x = Vector::Zero(bar.b.size());
  const SolveResult r =
      bar.build({"method=mgpcg", "lowest_level=boomeramg", "smoother=chebyshev", "smoother.degree=3"})->solve(bar.b, x);
  CHECK(r.status == SolveStatus::converged);
  CHECK((x - x_ref).norm() <= 1e-6 * x_ref.norm());
}

TEST_CASE("lowest_level=auto: CHOLMOD below the break-even, BoomerAMG from it, the choice written into "
          "the options", "[multigrid][boomeramg][auto]") {
  CHECK(mg::choose_lowest_level(mg::kAmgLowestLevelUnknowns - 1) == "cholmod");
  CHECK(mg::choose_lowest_level(mg::kAmgLowestLevelUnknowns) == "boomeramg");
  // The coarsest of a refined mesh's coarser meshes passes its own break-even.
  CHECK(mg::choose_lowest_level(mg::kAmgCoarseMeshUnknowns - 1, mg::kAmgCoarseMeshUnknowns) == "cholmod");
  CHECK(mg::choose_lowest_level(mg::kAmgCoarseMeshUnknowns, mg::kAmgCoarseMeshUnknowns) == "boomeramg");
  // Another break-even where a caller names one.
  CHECK(mg::choose_lowest_level(119999, 120000) == "cholmod");
  CHECK(mg::choose_lowest_level(120000, 120000) == "boomeramg");
  Bar bar;  // a linear level of a few hundred unknowns
  SolverContext ctx;
  ctx.levels = &bar.h;
  const Config c = Config::from_pairs({"method=mgpcg"}, "test");
  make_solver(c, ctx);
  CHECK(c.to_string().find("lowest_level.method=cholmod") != std::string::npos);
  // BoomerAMG named as the lowest level takes the measured lowest-level settings; the user's win.
  const Config a = Config::from_pairs({"method=mgpcg", "lowest_level=boomeramg"}, "test");
  make_solver(a, ctx);
  CHECK(a.to_string().find("lowest_level.relax_type=16") != std::string::npos);
  const Config u = Config::from_pairs({"method=mgpcg", "lowest_level=boomeramg", "lowest_level.relax_type=8"}, "test");
  make_solver(u, ctx);
  CHECK(u.to_string().find("lowest_level.relax_type=8") != std::string::npos);

  // Above the break-even (the quadratic cube of 14^3 boxes: 44,937 linear-level unknowns, known
  // from the hierarchy's coordinates without assembling anything): MGPCG takes BoomerAMG;
  // stationary PMG, and lowest-level keys given without a method, keep CHOLMOD.
  const TetMesh cube = box_mesh_24(14, 14, 14, 1.0, 1.0, 1.0);
  const DegreeHierarchy big{cube, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.z() < 1e-12; }};
  REQUIRE(static_cast<index_t>(big.node_coordinates(0).size()) >= mg::kAmgLowestLevelUnknowns);
  SolverContext bctx;
  bctx.levels = &big;
  auto chosen = [&](std::vector<std::string> o) {
    const Config k = Config::from_pairs(o, "test");
    make_solver(k, bctx);
    return k.to_string();
  };
  CHECK(chosen({"method=mgpcg"}).find("lowest_level.method=boomeramg") != std::string::npos);
  CHECK(chosen({"method=mgpcg", "lowest_level=auto"}).find("lowest_level.method=boomeramg") != std::string::npos);
  CHECK(chosen({"method=pmg"}).find("lowest_level.method=cholmod") != std::string::npos);
  CHECK(chosen({"method=mgpcg", "lowest_level.blas_threads=0"}).find("lowest_level.method=cholmod") != std::string::npos);
}

TEST_CASE("BoomerAMG on the coarsest of a refined mesh's coarser meshes runs kAmgCoarseMeshCycles V-cycles "
          "unless told otherwise, and solves as CHOLMOD there does", "[multigrid][boomeramg][auto]") {
  std::vector<Refinement> record;
  const TetMesh mesh = refine_uniform(box_mesh_24(3, 1, 1, 1.0, 0.4, 0.4), 1, &record);
  DegreeHierarchy h{mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }};
  h.set_refinements(record);
  h.assemble(nullptr);
  const Vector b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
  SolverContext ctx;
  ctx.levels = &h;
  auto run = [&](std::vector<std::string> o, std::string& options, Vector& x) {
    o.insert(o.end(), {"method=mgpcg", "tol=1e-10", "coarse_meshes=on"});
    const Config c = Config::from_pairs(o, "test");
    auto s = make_solver(c, ctx);
    s->setup(h.matrix(h.num_levels() - 1));
    x = Vector::Zero(b.size());
    const SolveResult r = s->solve(b, x);
    options = c.to_string();
    return r;
  };
  std::string chol_options, amg_options, one_options;
  Vector x_chol, x_amg, x_one;
  const SolveResult chol = run({"lowest_level=cholmod"}, chol_options, x_chol);
  const SolveResult amg = run({"lowest_level=boomeramg"}, amg_options, x_amg);
  const SolveResult one = run({"lowest_level=boomeramg", "lowest_level.cycles=1"}, one_options, x_one);
  REQUIRE(chol.status == SolveStatus::converged);
  REQUIRE(amg.status == SolveStatus::converged);
  REQUIRE(one.status == SolveStatus::converged);
  CHECK(amg_options.find("lowest_level.cycles=" + std::to_string(kAmgCoarseMeshCycles)) != std::string::npos);
  CHECK(one_options.find("lowest_level.cycles=1") != std::string::npos);
  CHECK((x_amg - x_chol).norm() <= 1e-8 * x_chol.norm());
  CHECK((x_one - x_chol).norm() <= 1e-8 * x_chol.norm());
  // More V-cycles per application: no more outer iterations than one.
  INFO("iterations: CHOLMOD " << chol.iterations << ", BoomerAMG x" << kAmgCoarseMeshCycles << " " << amg.iterations
                              << ", x1 " << one.iterations);
  CHECK(amg.iterations <= one.iterations);
  // On the linear level itself (no coarser meshes) BoomerAMG keeps its one V-cycle.
  const Config off = Config::from_pairs({"method=mgpcg", "coarse_meshes=off", "lowest_level=boomeramg"}, "test");
  make_solver(off, ctx);
  CHECK(off.to_string().find("lowest_level.cycles") == std::string::npos);
}

TEST_CASE("an AMG lowest level on the matrix-free route: the cube's solution as with CHOLMOD, iterations bounded, "
          "the set-up by stage", "[multigrid][boomeramg][auto]") {
  const TetMesh mesh = box_mesh_24(5, 5, 5, 1.0, 1.0, 1.0);
  DegreeHierarchy h{mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.z() < 1e-12; }};
  const Vector b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
  SolverContext ctx;
  ctx.levels = &h;
  auto run = [&](const std::string& lowest, Vector& x) {
    auto s = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-10", "lowest_level=" + lowest}, "test"), ctx);
    REQUIRE(s->needs().matrix_free);
    const LinearOperator& A = h.bind(*s).prepare();
    s->setup(A);
    x = Vector::Zero(b.size());
    const SolveResult r = s->solve(b, x);
    Vector res;
    A.residual(b, x, res);
    CHECK(res.norm() <= 2e-10 * b.norm());  // the true residual, on the finest operator
    // The set-up by stage names the lowest level's solver and adds up to no more than the set-up.
    const TimingBreakdown st = s->setup_timings();
    REQUIRE_FALSE(st.empty());
    CHECK(st.to_string().find("lowest level (" + lowest + ")") != std::string::npos);
    return r;
  };
  Vector x_chol, x_amg;
  const SolveResult chol = run("cholmod", x_chol);
  const SolveResult amg = run("boomeramg", x_amg);
  INFO("MGPCG iterations: CHOLMOD lowest level " << chol.iterations << ", BoomerAMG " << amg.iterations);
  CHECK(chol.status == SolveStatus::converged);
  CHECK(amg.status == SolveStatus::converged);
  CHECK(amg.iterations <= 4 * chol.iterations);  // measured 19 against 7 on the large cubes
  CHECK((x_amg - x_chol).norm() <= 1e-8 * x_chol.norm());
}

TEST_CASE("an AMG lowest level in corotational time steps: the same motion as CHOLMOD's", "[multigrid][boomeramg][auto]") {
  const TetMesh mesh = box_mesh_24(4, 1, 1, 4.0, 1.0, 1.0);
  auto simulate = [&](const std::string& lowest) {
    DegreeHierarchy h(mesh, 2, Material{5e5, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; });
    SolverContext ctx;
    ctx.levels = &h;
    auto s = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-10", "lowest_level=" + lowest}, "test"), ctx);
    SimulationParams sp;
    sp.dt = 0.01;
    const Vector f = h.finest().gravity(Vec3(0, 0, -9.81));
    ImplicitEuler sim(h, *s, f, sp);
    int iterations = 0;
    for (int k = 0; k < 5; ++k) {
      const StepStats st = sim.step();
      CHECK(st.residual <= 2e-10);
      iterations = std::max(iterations, st.iterations);
    }
    return std::make_pair(Vector(sim.displacement()), iterations);
  };
  const auto [u_chol, it_chol] = simulate("cholmod");
  const auto [u_amg, it_amg] = simulate("boomeramg");
  INFO("most MGPCG iterations per step: CHOLMOD " << it_chol << ", BoomerAMG " << it_amg);
  CHECK(u_chol.norm() > 0);
  CHECK((u_amg - u_chol).norm() <= 1e-7 * u_chol.norm());
  CHECK(it_amg <= 4 * it_chol + 2);
}

TEST_CASE("bad AMG lowest levels: rigid modes without coordinates, a set-up failure and a useless lowest level are "
          "clear errors or reported failures", "[multigrid][boomeramg][errors]") {
  Bar bar;
  // User levels know no coordinates: the rigid-body vectors are refused, naming the key.
  const Csr A0 = bar.h.matrix(0).to_csr(), A1 = bar.h.matrix(1).to_csr();
  const mg::UserLevels levels({view_of(A0), view_of(A1)}, {view_of(bar.h.prolongation(1))}, {});
  SolverContext ctx;
  ctx.levels = &levels;
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=mgpcg", "lowest_level=boomeramg", "lowest_level.nodal=4",
                                                    "lowest_level.interp_vectors=rigid"}, "test"), ctx),
                    Catch::Contains("interp_vectors") && Catch::Contains("coordinates"));
  // A lowest level that does nothing useful (one sweep of an AMG that cannot coarsen) still gives
  // a converged answer or an honest failure, never a wrong success.
  auto s = bar.build({"method=mgpcg", "lowest_level=boomeramg", "lowest_level.max_levels=2",
                      "lowest_level.max_coarse_size=1000000", "lowest_level.relax_coarse=8"});
  Vector x = Vector::Zero(bar.b.size());
  try {
    const SolveResult r = s->solve(bar.b, x);
    REQUIRE(r.status == SolveStatus::converged);
    Vector res;
    bar.h.matrix(1).residual(bar.b, x, res);
    CHECK(res.norm() <= 2e-8 * bar.b.norm());
  } catch (const SolveError& e) {
    CHECK(e.result.status != SolveStatus::converged);  // an honest failure
  }
}

TEST_CASE("BoomerAMG's num_functions follows the matrix: 3 for 3x3 blocks, 1 for a scalar system",
          "[hypre][amg]") {
  // The 5-point Laplacian on a 30 x 30 grid: 900 unknowns, a multiple of 3, yet scalar.
  const index_t m = 30;
  std::vector<Triplet> t;
  for (index_t i = 0; i < m; ++i)
    for (index_t j = 0; j < m; ++j) {
      const index_t r = i * m + j;
      t.emplace_back(r, r, 4.0);
      if (i > 0) t.emplace_back(r, r - m, -1.0);
      if (i + 1 < m) t.emplace_back(r, r + m, -1.0);
      if (j > 0) t.emplace_back(r, r - 1, -1.0);
      if (j + 1 < m) t.emplace_back(r, r + 1, -1.0);
    }
  const Csr poisson = Csr::from_triplets(m * m, m * m, t);
  const Csr lattice = spring_lattice(5).to_csr();
  for (const auto& [A, functions] : {std::pair<const Csr*, const char*>{&poisson, "num_functions=1"},
                                     {&lattice, "num_functions=3"}}) {
    hypre::BoomerAMG amg;
    amg.setup(*A);
    CHECK_THAT(amg.describe(), Catch::Contains(functions));
    Vector x;
    const Vector b = Vector::Ones(A->rows());
    amg.apply(b, x);
    CHECK(x.allFinite());
  }
  // Rigid-body interpolation vectors need the blocks.
  hypre::BoomerAMGParams p;
  p.interp_vectors = 3;
  p.nodal = 4;
  hypre::BoomerAMG rigid(p);
  CHECK_THROWS_WITH(rigid.setup(poisson), Catch::Contains("scalar system"));
}
