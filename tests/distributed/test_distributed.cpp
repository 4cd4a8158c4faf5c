// The p-multigrid across MPI ranks (pmg::distributed on PETSc) against the serial pmgkit: the
// operator products, transfers and lowest-level matrix equal the serial ones, the solutions equal
// the serial MGPCG's, the iteration counts equal the one-rank run's within one, and bad input is a
// clear error on every rank; the time step across ranks follows the serial implicit Euler. The same executable runs on 1 rank (ctest's plain run) and under
// mpirun -np 2, 3 and 4 (oversubscribed on these 2-core machines).
#include "pmg/distributed/dynamics.hpp"
#include "pmg/distributed/mgpcg.hpp"
#include "pmg/distributed/rank_hierarchy.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/mesh_io.hpp"
#include "pmg/fem/simulation.hpp"
#include "pmg/petsc/pcmg.hpp"
#include "pmg/sparse/factory.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace pmg;
using namespace pmg::fem;

namespace {

int world_size() {
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

/// The same random vector on every rank.
Vector random_vector(Eigen::Index n, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector x(n);
  for (Eigen::Index i = 0; i < n; ++i) x[i] = u(gen);
  return x;
}

double relative(const Vector& a, const Vector& b) { return (a - b).norm() / b.norm(); }

/// A bar clamped at x = 0 under gravity, of degree p.
struct Bar {
  TetMesh mesh;
  DegreeHierarchy h;
  Vector b;
  Bar(int p, index_t nx = 6, index_t ny = 2, index_t nz = 2)
      : mesh(box_mesh_24(nx, ny, nz, 1.0, 0.3, 0.3)),
        h(mesh, p, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }) {
    b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
  }
};

/// pmgkit's serial MGPCG solution (matrix-free levels, CHOLMOD lowest level) to tol.
Vector serial_solution(DegreeHierarchy& h, const Vector& b, const std::string& tol, int* iterations = nullptr) {
  auto s = make_solver(Config::from_pairs({"method=mgpcg", "tol=" + tol, "lowest_level=cholmod"}, "test"),
                       SolverContext{&h, nullptr});
  const LinearOperator& A = h.bind(*s).prepare();
  s->setup(A);
  Vector x = Vector::Zero(b.size());
  const SolveResult r = s->solve(b, x);
  if (iterations) *iterations = r.iterations;
  return x;
}

}  // namespace

TEST_CASE("every rank holds elements, every free node one owner, the numbering contiguous", "[distributed]") {
  Bar bar(3);
  dist::RankHierarchy rh(bar.h, MPI_COMM_WORLD);
  CHECK(static_cast<int>(rh.element_parts().size()) == bar.mesh.num_tets());
  CHECK(rh.mesh().num_tets() > 0);
  for (int l = 0; l < rh.num_levels(); ++l) {
    long owned = rh.owned(l), total = 0;
    MPI_Allreduce(&owned, &total, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    CHECK(total == bar.h.model(l).assembler().num_free());
    CHECK(rh.global_nodes(l) == total);
    // Owned nodes come first in no particular order, but all of them are among the local ones.
    index_t found = 0;
    for (index_t g : rh.global(l)) found += g >= rh.first(l) && g < rh.first(l) + rh.owned(l);
    CHECK(found == rh.owned(l));
    // The gather of the owned parts is the serial vector.
    const Vector x = random_vector(3 * bar.h.model(l).assembler().num_free(), 7 + l);
    CHECK(rh.gather(l, rh.owned_part(l, x)) == x);
  }
}

TEST_CASE("operator products, transfers and the lowest-level matrix equal the serial ones", "[distributed]") {
  for (int p : {2, 3}) {
    Bar bar(p);
    dist::RankHierarchy rh(bar.h, MPI_COMM_WORLD);
    rh.bring_to(bar.h);  // R = I, stiffness only: the rank's operators and degree-1 matrix
    petsc::PMultigridCg mg(MPI_COMM_WORLD, {});
    mg.setup(rh.rank_levels());
    bar.h.assemble_level(0, nullptr);
    for (int l = 0; l < p; ++l) {
      const index_t n = 3 * bar.h.model(l).assembler().num_free();
      const Vector x = random_vector(n, 11 + l);
      Vector y_serial(n), y_owned;
      if (l == 0)
        bar.h.matrix(0).apply(x, y_serial);
      else
        bar.h.matrix_free(l).apply(x, y_serial);
      mg.multiply(l, rh.owned_part(l, x), y_owned);
      INFO("degree " << p << ", level " << l);
      CHECK(relative(rh.gather(l, y_owned), y_serial) < 1e-12);
      if (l == 0) continue;
      // Prolongation: the scalar P on each component.
      const Csr& P = bar.h.prolongation(l);
      const Vector xc = random_vector(3 * P.cols(), 23 + l);
      Vector yf = Vector::Zero(3 * P.rows());
      for (index_t i = 0; i < P.rows(); ++i)
        for (offset_t k = P.pattern().row_ptr[i]; k < P.pattern().row_ptr[i + 1]; ++k)
          for (int c = 0; c < 3; ++c) yf[3 * i + c] += P.values()[k] * xc[3 * P.pattern().col_idx[k] + c];
      Vector yp;
      mg.prolong(l, rh.owned_part(l - 1, xc), yp);
      CHECK(relative(rh.gather(l, yp), yf) < 1e-12);
    }
  }
}

TEST_CASE("the distributed solve equals the serial MGPCG, its iterations the one-rank run's", "[distributed]") {
  for (int p : {2, 3}) {
    Bar bar(p, 8, 2, 2);
    int serial_iterations = 0;
    const Vector x_serial = serial_solution(bar.h, bar.b, "1e-11", &serial_iterations);
    for (const char* lowest : {"mumps", "gamg", "boomeramg"}) {
      INFO("degree " << p << ", lowest level " << lowest);
      dist::DistributedMgpcgParams params;
      params.tol = 1e-11;
      params.lowest_level = lowest;
      params.smoothing_steps = 3;  // the serial mgpcg's smoother degree: the cycles' strength compared below
      dist::DistributedMgpcg world(bar.h, params, MPI_COMM_WORLD);
      dist::DistributedMgpcg self(bar.h, params, MPI_COMM_SELF);
      const LinearOperator& A = bar.h.bind(world).prepare();
      world.setup(A);
      self.setup(A);
      Vector x_world, x_self;
      const SolveResult rw = world.solve(bar.b, x_world);
      const SolveResult rs = self.solve(bar.b, x_self);
      CHECK(rw.ok());
      CHECK(rw.true_rel_residual < 2e-11);
      CHECK(relative(x_world, x_serial) < 1e-8);
      CHECK(relative(x_self, x_serial) < 1e-8);
      CHECK(std::abs(rw.iterations - rs.iterations) <= 1);
      // The true residual with the serial operator.
      Vector r;
      A.residual(bar.b, x_world, r);
      CHECK(r.norm() / bar.b.norm() < 2e-11);
      // With the same lowest level and smoother degree, PETSc's cycle (first-kind Chebyshev) is nearly
      // as strong as the serial one (optimised fourth kind).
      if (std::string(lowest) == "mumps") CHECK(rw.iterations <= serial_iterations + 6);
    }
  }
}

TEST_CASE("symmetry planes through the Solver seam: petsc-mgpcg equals the serial MGPCG, held entries as identity rows",
          "[distributed][symmetry]") {
  // A quarter bar: u_y held on y = max, u_z on z = max (the serial hierarchy's component masks).
  const TetMesh mesh = box_mesh_24(6, 2, 2, 1.0, 0.15, 0.15);
  std::vector<char> masks(mesh.vertices.size(), 0);
  for (size_t v = 0; v < masks.size(); ++v) {
    if (std::abs(mesh.vertices[v].y() - 0.15) < 1e-9) masks[v] |= 2;
    if (std::abs(mesh.vertices[v].z() - 0.15) < 1e-9) masks[v] |= 4;
  }
  DegreeHierarchy h(mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }, masks);
  const std::vector<char>& held = h.finest().constrained_free_dofs();
  REQUIRE(!held.empty());
  Vector b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0.0, -9.81, -9.81)));
  const Vector x_serial = serial_solution(h, b, "1e-11");
  dist::DistributedMgpcgParams params;
  params.tol = 1e-11;
  dist::DistributedMgpcg world(h, params, MPI_COMM_WORLD);
  world.setup(h.bind(world).prepare());
  Vector x;
  CHECK(world.solve(b, x).ok());
  CHECK(relative(x, x_serial) < 1e-8);
  double on_planes = 0.0;
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) on_planes = std::max(on_planes, std::abs(x[static_cast<Eigen::Index>(i)]));
  CHECK(on_planes == 0.0);
  // A right-hand side with values on the held entries: x = b there, as the serial identity rows.
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) b[static_cast<Eigen::Index>(i)] = 1e-3 * static_cast<double>(i % 7 + 1);
  const Vector y_serial = serial_solution(h, b, "1e-11");
  Vector y;
  CHECK(world.solve(b, y).ok());
  CHECK(relative(y, y_serial) < 1e-8);
}

TEST_CASE("the solver contract: every guess and tolerance, a scaled system, a time step's weights", "[distributed]") {
  Bar bar(2);
  dist::DistributedMgpcgParams params;
  for (double tol : {1e-4, 1e-8, 1e-10}) {
    params.tol = tol;
    dist::DistributedMgpcg s(bar.h, params);
    const LinearOperator& A = bar.h.bind(s).prepare();
    s.setup(A);
    const Vector x_star = random_vector(A.rows(), 3);
    Vector b;
    A.apply(x_star, b);
    for (int guess = 0; guess < 3; ++guess) {
      INFO("tol " << tol << ", guess " << guess);
      Vector x = guess == 0 ? Vector::Zero(A.rows()) : guess == 1 ? random_vector(A.rows(), 9) : x_star;
      Vector r0;
      A.residual(b, x, r0);
      if (guess < 2) {
        const SolveResult r = s.solve(b, x);
        CHECK(r.ok());
        Vector r1;
        A.residual(b, x, r1);
        CHECK(r1.norm() <= 2 * tol * r0.norm() * (1 + 1e-12));
      } else {
        // The exact solution: its residual is rounding (different in the serial and the
        // distributed sums of the same element contributions), and no solve can divide it by
        // 1/tol: a failure that says so, as pmgkit's own CG ...
        try {
          s.solve(b, x);
        } catch (const SolveError& e) {
          CHECK(e.result.status == SolveStatus::stagnated);
        }
        // ... or, with the floor a warm-started time step sets, kept.
        dist::DistributedMgpcgParams floored = params;
        floored.rhs_floor = 1e-12;
        dist::DistributedMgpcg f(bar.h, floored);
        f.setup(A);
        Vector y = x_star;
        const SolveResult r = f.solve(b, y);
        CHECK(r.ok());
        CHECK(r.iterations <= 1);
        Vector r1;
        A.residual(b, y, r1);
        CHECK(r1.norm() <= 2e-12 * b.norm());
      }
    }
  }
  SECTION("a scaled system: units change nothing, an extreme scale is never a wrong success") {
    for (double scale : {1e6, 1e-6, 1e-200}) {
      INFO("Young's modulus x " << scale);
      Bar scaled(2);
      scaled.h.set_stiffness_scale(std::vector<double>(scaled.mesh.num_tets(), scale));
      dist::DistributedMgpcg a(bar.h), b(scaled.h);
      a.setup(bar.h.bind(a).prepare());
      Vector xa, xb;
      const SolveResult ra = a.solve(bar.b, xa);
      try {
        b.setup(scaled.h.bind(b).prepare());
        const SolveResult rb = b.solve(scaled.b * scale, xb);
        CHECK(rb.ok());
        CHECK(std::abs(ra.iterations - rb.iterations) <= 1);
        CHECK(relative(xb, xa) < 1e-6);
      } catch (const Error& e) {  // SolveError included: a failure that says so
        CHECK(scale == 1e-200);
        CHECK_FALSE(std::string(e.what()).empty());
      }
    }
  }
  SECTION("mass and stiffness weights and rotations follow the serial level (update)") {
    dist::DistributedMgpcg s(bar.h);
    s.setup(bar.h.bind(s).prepare());
    // A time step's operator: 2 M + 1e-3 K_R with a rotation per element.
    fem::Rotations R(bar.mesh.num_tets(), Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()).toRotationMatrix());
    const LinearOperator& A = bar.h.bind(s).prepare(&R, {2.0, 1e-3});
    s.update();
    Vector x;
    const SolveResult r = s.solve(bar.b, x);
    CHECK(r.ok());
    Vector res;
    A.residual(bar.b, x, res);
    CHECK(res.norm() <= 2 * 1e-8 * bar.b.norm());
  }
}

TEST_CASE("bad input is one clear error on every rank", "[distributed]") {
  Bar bar(2);
  // A set-up with these options fails with a message containing `what`.
  auto refused = [&](const dist::DistributedMgpcgParams& params, const std::string& what) {
    dist::DistributedMgpcg s(bar.h, params);
    CHECK_THROWS_WITH(s.setup(bar.h.bind(s).prepare()), Catch::Contains(what));
  };
  SECTION("an unknown lowest level") {
    dist::DistributedMgpcgParams params;
    params.lowest_level = "lu";
    refused(params, "unknown lowest level 'lu'");
  }
  SECTION("mgpcg's serial lowest level names the distributed one") {
    dist::DistributedMgpcgParams params;
    params.lowest_level = "cholmod";
    refused(params, "across ranks the sparse Cholesky is 'mumps'");
  }
  SECTION("hypre is BoomerAMG's alias; PETSc's options still choose the smoothers' preconditioner") {
    dist::DistributedMgpcgParams params;
    params.lowest_level = "hypre";
    params.options = "-mg_levels_pc_type pbjacobi";
    params.tol = 1e-10;
    dist::DistributedMgpcg s(bar.h, params);
    s.setup(bar.h.bind(s).prepare());
    Vector x;
    const SolveResult r = s.solve(bar.b, x);
    CHECK(r.ok());
    CHECK(s.describe().find("lowest level boomeramg") != std::string::npos);
  }
  SECTION("more ranks than elements") {
    if (world_size() < 2) return;
    TetMesh one;
    one.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
    one.tets = {{0, 1, 2, 3}};
    DegreeHierarchy h(one, 2, Material{}, [](const Vec3& X) { return X.z() < 1e-12; });
    CHECK_THROWS_WITH(dist::RankHierarchy(h, MPI_COMM_WORLD), Catch::Contains("cannot fill"));
  }
  SECTION("a bad PETSc option names itself") {
    dist::DistributedMgpcgParams params;
    params.options = "-mg_levels_ksp_type no_such_ksp";
    refused(params, "no_such_ksp");
  }
  SECTION("a solve that cannot converge in its iterations fails on every rank") {
    dist::DistributedMgpcgParams params;
    params.max_iterations = 2;
    params.tol = 1e-14;
    dist::DistributedMgpcg s(bar.h, params);
    s.setup(bar.h.bind(s).prepare());
    Vector x;
    CHECK_THROWS_AS(s.solve(bar.b, x), SolveError);
  }
}

TEST_CASE("the time step across ranks follows the serial implicit Euler", "[distributed][simulation]") {
  const bool corotational = GENERATE(true, false);
  CAPTURE(corotational);
  Bar bar(2);
  const Vector f = bar.h.finest().gravity(Vec3(0, 0, -9.81));
  SimulationParams sp;
  sp.dt = 0.01;
  sp.corotational = corotational;
  sp.rayleigh_alpha = 0.5;
  // A start away from rest: a bent state moving, so that rotations and both energies matter.
  const ElasticityModel& m = bar.h.finest();
  Vector u0 = m.interpolate([](const Vec3& X) { return Vec3(0.0, 0.05 * X.x() * X.x(), -0.1 * X.x() * X.x()); });
  Vector v0 = m.interpolate([](const Vec3& X) { return Vec3(0.0, 0.0, 0.3 * X.x()); });
  for (index_t i = 0; i < m.num_nodes(); ++i)
    if (m.is_fixed(i)) u0.segment<3>(3 * i).setZero(), v0.segment<3>(3 * i).setZero();

  DegreeHierarchy serial_h(bar.mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; });
  auto solver = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-12", "rhs_floor=1e-14", "lowest_level=cholmod"}, "test"),
                            SolverContext{&serial_h, nullptr});
  ImplicitEuler serial(serial_h, *solver, f, sp);
  serial.set_state(u0, v0);
  dist::DistributedMgpcgParams params;
  params.tol = 1e-12;
  params.rhs_floor = 1e-14;
  dist::DistributedEuler across(bar.h, f, sp, params);
  across.set_state(u0, v0);
  // The probe: the far corner's element at its centre.
  const index_t probe_element = bar.mesh.num_tets() - 1;
  const Eigen::Vector4d centre = Eigen::Vector4d::Constant(0.25);
  for (int n = 1; n <= 6; ++n) {
    CAPTURE(n);
    const StepStats a = serial.step(), b = across.step();
    CHECK(b.step == n);
    CHECK(b.time == Approx(a.time));
    CHECK(b.residual <= 2e-12);
    const Vector u = across.gather_displacement();
    REQUIRE(u.size() == serial.displacement().size());
    CHECK(relative(u, serial.displacement()) <= 1e-8);
    CHECK(across.kinetic_energy() == Approx(serial.kinetic_energy()).epsilon(1e-8));
    CHECK(across.elastic_energy() == Approx(serial.elastic_energy()).epsilon(1e-8));
    CHECK(across.external_work() == Approx(serial.external_work()).epsilon(1e-8));
    const Vec3 p = across.displacement_at(probe_element, centre);
    CHECK((p - m.displacement_at(serial.displacement(), probe_element, centre)).norm() <= 1e-8 * p.norm());
  }
  CHECK(across.steps() == 6);
  CHECK_THROWS_AS(across.displacement_at(-1, centre), InputError);
}

TEST_CASE("the time step across ranks refuses what the serial one refuses, on every rank", "[distributed][simulation]") {
  Bar bar(2);
  const Vector f = bar.h.finest().gravity(Vec3(0, 0, -9.81));
  SimulationParams bad_dt;
  bad_dt.dt = -1.0;
  CHECK_THROWS_WITH(dist::DistributedEuler(bar.h, f, bad_dt), Catch::Contains("time step must be positive"));
  CHECK_THROWS_WITH(dist::DistributedEuler(bar.h, Vector::Ones(3), SimulationParams{}), Catch::Contains("external force"));
  dist::DistributedEuler across(bar.h, f, SimulationParams{});
  Vector u = Vector::Zero(bar.h.finest().num_dofs());
  u[0] = std::nan("");
  CHECK_THROWS_WITH(across.set_state(u, Vector::Zero(u.size())), Catch::Contains("not finite"));
  SECTION("a step whose solve cannot converge fails on every rank, naming the step") {
    dist::DistributedMgpcgParams params;
    params.max_iterations = 1;
    params.tol = 1e-14;
    dist::DistributedEuler failing(bar.h, f, SimulationParams{}, params);
    CHECK_THROWS_WITH(failing.step(), Catch::Contains("step 1") && Catch::Contains("petsc-mgpcg failed"));
  }
}
