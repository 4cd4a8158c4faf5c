// Property-based tests of the solver contract (pmg/sparse/solver.hpp), for every registered method
// but the GPU ones: over random SPD systems, scalings from 1e-300 to 1e300, starting guesses (zero,
// random, the exact solution), per-call tolerances, repeated calls and update()s,
//   - a reported success means the requested true residual was reached (iterative methods:
//     ||b - A x|| <= 2 tol ||b - A x0||, the allowance of their true-residual check; direct
//     methods: ||b - A x|| <= tol ||b||; preconditioners used as solvers ask for nothing and say
//     "completed");
//   - a failure is an exception (SolveError for a solve, InputError or Error for a set-up) whose
//     message names the method or the cause: never a crash, a NaN reported as success, or silence;
//   - a call never changes what the next one does: the same solve after a failed one, or after an
//     update() with the same values, gives the same answer.
// The cases are drawn from a fixed seed. PMG_PROPERTY_CASES sets how many systems each method
// sees (default 2: the README test command); the label "properties" runs 40 (CI).
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/user_levels.hpp"
#include "pmg/petsc/petsc.hpp"
#include "pmg/sparse/bcsr.hpp"
#include "pmg/solvers.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

using namespace pmg;

namespace {

int cases() {
  const char* s = std::getenv("PMG_PROPERTY_CASES");
  const int n = s ? std::atoi(s) : 2;
  return n > 0 ? n : 2;
}

/// A random symmetric, strictly diagonally dominant (so SPD) matrix of nb 3x3 blocks on a random
/// sparse pattern, scaled by `scale`.
Csr random_spd(std::mt19937& gen, index_t nb, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), pos(0.05, 2.0);
  std::uniform_int_distribution<index_t> pick(0, nb - 1);
  std::vector<std::vector<double>> offsum(nb, std::vector<double>(3, 0.0));
  std::vector<Triplet> t;
  auto add_block = [&](index_t I, index_t J) {
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 3; ++c) {
        const double v = u(gen);
        t.emplace_back(3 * I + a, 3 * J + c, v);
        t.emplace_back(3 * J + c, 3 * I + a, v);
        offsum[I][a] += std::abs(v);
        offsum[J][c] += std::abs(v);
      }
  };
  for (index_t I = 0; I < nb; ++I) {
    if (I + 1 < nb) add_block(I, I + 1);  // connected
    for (int k = 0; k < 2; ++k) {
      const index_t J = pick(gen);
      if (J != I && J != I + 1 && J + 1 != I) add_block(I, J);
    }
  }
  for (index_t I = 0; I < nb; ++I) {
    const double c01 = 0.3 * u(gen), c02 = 0.3 * u(gen), c12 = 0.3 * u(gen);
    const double off[3] = {std::abs(c01) + std::abs(c02), std::abs(c01) + std::abs(c12), std::abs(c02) + std::abs(c12)};
    for (int a = 0; a < 3; ++a) t.emplace_back(3 * I + a, 3 * I + a, offsum[I][a] + off[a] + pos(gen));
    t.emplace_back(3 * I, 3 * I + 1, c01), t.emplace_back(3 * I + 1, 3 * I, c01);
    t.emplace_back(3 * I, 3 * I + 2, c02), t.emplace_back(3 * I + 2, 3 * I, c02);
    t.emplace_back(3 * I + 1, 3 * I + 2, c12), t.emplace_back(3 * I + 2, 3 * I + 1, c12);
  }
  Csr A = Csr::from_triplets(3 * nb, 3 * nb, t);
  for (double& v : A.values()) v *= scale;
  return A;
}

/// What a method asks of a solve: iterative (a tolerance on ||r|| / ||r0||), direct (on
/// ||r|| / ||b||) or nothing (a preconditioner's one correction).
enum class Kind { iterative, direct, one_shot };

Kind kind_of(const std::string& method) {
  if (method_accepts_key(method, "max_iterations")) return Kind::iterative;
  if (method_accepts_key(method, "refinement_steps")) return Kind::direct;
  return Kind::one_shot;
}

bool testable(const SolverInfo& s) {
  if (s.component == "gpu") return false;  // tests/gpu, on a device
  // petsc-mgpcg partitions a mesh, which these user levels lack: its contract cases (guesses,
  // tolerances, a scaled system) are in tests/distributed, on 1 to 4 ranks.
  if (s.component == "distributed") return false;
  // mixed-minres and mixed-gmres solve saddle points [A Bᵀ; B -C], not SPD systems: their cases
  // (guesses, tolerances, breakdown, the blocks' answers against a direct solve) are in
  // tests/sparse/test_saddle_point.cpp and tests/multigrid/test_mixed.cpp; fieldsplit-gmres's
  // against mixed-gmres in tests/tools.
  if (s.name == "mixed-minres" || s.name == "mixed-gmres" || s.name == "fieldsplit-gmres") return false;
  return s.component != "petsc" || mg::petsc_available();
}

/// One system and the pieces a multigrid method needs (user levels from an FEM hierarchy).
struct Case {
  std::vector<Csr> level_matrices, prolongations;  // only for methods with levels
  std::unique_ptr<mg::UserLevels> levels;
  Csr A;                                           // without levels
  std::unique_ptr<Bcsr> blocks;                    // A as 3x3 blocks, for the methods reading them
  const LinearOperator* op = nullptr;
  /// The FEM hierarchy behind the user levels: the vertex patches of the patch method (the user
  /// levels define none), on the same numbering.
  const mg::LevelProvider* fem = nullptr;
};

/// A quadratic bar's two levels (free dofs only) with its matrices scaled by `scale`.
void fem_levels(Case& c, double scale) {
  static const fem::TetMesh mesh = fem::box_mesh_24(2, 1, 1, 1.0, 0.4, 0.4);
  static fem::DegreeHierarchy h(mesh, 2, fem::Material{1e5, 0.3, 1e3}, [](const fem::Vec3& X) { return X.x() < 1e-12; });
  static bool assembled = false;
  if (!assembled) h.assemble(nullptr), assembled = true;
  std::vector<CsrView> mats, ps;
  for (int l = 0; l < h.num_levels(); ++l) {
    c.level_matrices.push_back(h.matrix(l).to_csr());
    for (double& v : c.level_matrices.back().values()) v *= scale;
  }
  for (int l = 1; l < h.num_levels(); ++l) c.prolongations.push_back(h.prolongation(l));
  for (const auto& m : c.level_matrices) mats.push_back(view_of(m));
  for (const auto& p : c.prolongations) ps.push_back(view_of(p));
  c.levels = std::make_unique<mg::UserLevels>(mats, ps, mg::UserLevelOptions{});
  c.op = &c.levels->matrix(c.levels->num_levels() - 1);
  c.fem = &h;
}

double norm_of_residual(const LinearOperator& A, const Vector& b, const Vector& x) {
  Vector r;
  A.residual(b, x, r);
  return r.norm();
}

/// Solves and checks the contract; returns whether the solve reported success. `what` describes
/// the case for failure messages.
bool solve_and_check(const Solver& s, Kind kind, double tol, const LinearOperator& A, const Vector& b, Vector& x,
                     const std::string& what) {
  INFO(what);
  const Vector x0 = x;
  // The reference of tol: ||b|| (||r0|| where b = 0), for iterative and direct methods alike.
  const double r0 = b.norm() > 0 ? b.norm() : norm_of_residual(A, b, x0);
  SolveResult r;
  try {
    r = s.solve(b, x);
  } catch (const SolveError& e) {
    if (std::getenv("PMG_PROPERTY_VERBOSE")) std::printf("  %s: %s\n", what.c_str(), e.what());
    CHECK_FALSE(std::string(e.what()).empty());
    CHECK_FALSE(e.result.ok());
    return false;
  }
  // Not thrown: a success (or, with throw_on_failure false, a failure its status names).
  REQUIRE(r.ok());
  REQUIRE(x.allFinite());
  const double rn = norm_of_residual(A, b, x);
  if (kind == Kind::iterative && std::isfinite(r0) && r0 > 0) CHECK(rn <= 2 * tol * r0 * (1 + 1e-12));
  if (kind == Kind::direct && r0 > 0) {
    // Within tol, or an answer at rounding level (backward error and growth, judge_direct_answer).
    Vector res(b.size());
    A.residual(b, x, res);
    CHECK(judge_direct_answer(A, b, x, res, tol).ok);
  }
  if (kind == Kind::one_shot) CHECK(r.status == SolveStatus::completed);
  return true;
}

}  // namespace

TEST_CASE("the solver contract holds for every method over random systems, scalings and guesses",
          "[contract][properties]") {
  register_all_solvers();
  const int n_cases = cases();
  for (const SolverInfo& info : registered_solvers()) {
    if (!testable(info)) continue;
    const std::string method = info.name;
    const Kind kind = kind_of(method);
    std::mt19937 gen(std::hash<std::string>{}(method) % 100000 + 7);
    std::uniform_int_distribution<int> exponent(-300, 300), guess(0, 2), size(4, 40);
    const double tols[] = {1e-4, 1e-8, 1e-10};
    int successes = 0, failures = 0, refused = 0;
    for (int k = 0; k < n_cases; ++k) {
      // The first cases of each method are the edges: unscaled, then 1e-300 and 1e300.
      const int e = k == 0 ? 0 : k == 1 ? -300 : k == 2 ? 300 : exponent(gen);
      const double scale = std::pow(10.0, e);
      const double tol = tols[k % 3];
      Case c;
      std::string what = method + ", case " + std::to_string(k) + ", matrix scale 1e" + std::to_string(e) +
                         ", tol " + std::to_string(tol);
      INFO(what);
      if (info.uses_levels) {
        fem_levels(c, scale);
      } else {
        c.A = random_spd(gen, size(gen), scale);
        c.op = &c.A;
        if (info.needs_blocks) {
          c.blocks = std::make_unique<Bcsr>(Bcsr::from_csr(c.A));
          c.op = c.blocks.get();
        }
      }
      const LinearOperator& A = *c.op;
      Config config = Config::from_pairs({"method=" + method}, "property test");
      if (kind == Kind::iterative || kind == Kind::direct) {
        char text[32];
        std::snprintf(text, sizeof text, "%.17g", tol);
        config.set("tol", text);
      }
      SolverContext ctx;
      ctx.levels = method == "patch" ? c.fem : c.levels.get();
      std::unique_ptr<Solver> s;
      try {
        s = make_solver(config, ctx);
        s->setup(A);
      } catch (const Error& err) {
        // A set-up may refuse a system (a block method on a scalar matrix, an overflowing scale):
        // by an exception that says what, never by a crash.
        CHECK_FALSE(std::string(err.what()).empty());
        CHECK(k > 0);  // never the unscaled case
        ++refused;
        continue;
      }
      // The exact solution x* with entries of order 1 / scale^0 (b = A x*).
      std::normal_distribution<double> normal;
      Vector x_star(A.rows());
      for (index_t i = 0; i < A.rows(); ++i) x_star[i] = normal(gen);
      Vector b;
      A.apply(x_star, b);
      if (!b.allFinite()) continue;  // the scale overflowed the product itself: nothing to ask
      const int g = k == 0 ? 0 : guess(gen);
      Vector x0 = g == 0 ? Vector::Zero(A.rows()) : g == 1 ? Vector(Vector::Random(A.rows())) : x_star;
      const std::string guess_name = g == 0 ? "zero" : g == 1 ? "random" : "the exact solution";
      Vector x1 = x0;
      const bool ok1 = solve_and_check(*s, kind, tol, A, b, x1, what + ", guess " + guess_name);
      if (k == 0) CHECK(ok1);  // an unscaled SPD system from zero: every method must succeed
      // A start at the answer (b = A x* to rounding) meets any tol >= 1e-10: it succeeds, at once.
      if (g == 2 && kind == Kind::iterative) CHECK(ok1);
      // Scale invariance over double's range: b far from 1 (as 1e-200 or 1e200) is solved as
      // well as b, and the answer scales with it.
      if (ok1 && kind != Kind::one_shot && e == 0) {  // (on a scaled matrix b * f would leave double range)
        for (const double f : {1e-200, 1e200}) {
          Vector xs = x0 * f;
          const bool ok = solve_and_check(*s, kind, tol, A, b * f, xs, what + ", b scaled by " + std::to_string(f));
          CHECK(ok);
          if (ok) CHECK((xs / f - x1).norm() <= std::max(1e-6, 100 * tol) * std::max(x1.norm(), x_star.norm()));
        }
      }
      ++(ok1 ? successes : failures);
      // A second right-hand side (whatever happens to it) does not change the next solve.
      Vector other = Vector::Constant(A.rows(), 1e300);
      try {
        s->solve(b * 1e-300, other);
      } catch (const Error&) {
      }
      Vector x2 = x0;
      const bool ok2 = solve_and_check(*s, kind, tol, A, b, x2, what + ", repeated");
      CHECK(ok1 == ok2);
      if (ok1 && ok2) CHECK((x2 - x1).norm() <= 1e-12 * x1.norm());
      // update() with the same values gives the same answer again.
      bool updated = true;
      try {
        s->update();
      } catch (const Error& err) {
        CHECK_FALSE(std::string(err.what()).empty());
        updated = false;
      }
      if (updated) {
        Vector x3 = x0;
        const bool ok3 = solve_and_check(*s, kind, tol, A, b, x3, what + ", after update()");
        CHECK(ok3 == ok1);
        if (ok1 && ok3) CHECK((x3 - x1).norm() <= 1e-10 * x1.norm());
      }
    }
    if (std::getenv("PMG_PROPERTY_VERBOSE"))
      std::printf("%-20s %3d solved, %3d failed by an exception, %3d refused at set-up\n", method.c_str(),
                  successes, failures, refused);
  }
}
