// The threading contract (pmg/sparse/solver.hpp, "Threads"): solvers of every kind used from
// several threads at once, each its own or one shared, give the answers they give alone. Built by
// the ThreadSanitizer stage of CI too (scripts/tsan.sh), where a data race fails the test.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/matrix_free.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/cholmod/cholmod_solver.hpp"
#include "pmg/petsc/petsc.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace pmg;
using namespace pmg::fem;

namespace {

/// A quadratic bar clamped at x = 0 (3 x 1 x 1 boxes: 1,000 unknowns), its free nodes' coordinates
/// and right-hand sides of four loads.
struct System {
  TetMesh mesh = box_mesh_24(3, 1, 1, 1.0, 0.3, 0.3);
  DegreeHierarchy h{mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }};
  std::vector<Vector> rhs;
  std::vector<double> xyz;
  System() {
    h.assemble(nullptr);
    for (int k = 0; k < 4; ++k) {
      Vec3 g(0, 0, 0);
      g[k % 3] = k < 3 ? -9.81 : 4.0;
      rhs.push_back(h.finest().restrict_to_free(h.finest().gravity(g)));
    }
    const Vector free = h.finest().free_positions();
    xyz.assign(free.data(), free.data() + free.size());
  }
  /// A solver of `spec` ("method key=value ..."), not set up.
  std::unique_ptr<Solver> make(const std::string& spec) {
    SolverContext ctx;
    ctx.coordinates = &xyz;
    ctx.levels = &h;
    std::vector<std::string> pairs;
    std::istringstream words(spec);
    for (std::string w; words >> w;) pairs.push_back(pairs.empty() ? "method=" + w : w);
    return make_solver(Config::from_pairs(pairs, "test"), ctx);
  }
  /// The operator `method` is set up on, the hierarchy brought up to date for it. The hierarchy
  /// is the caller's to guard (it is not a solver): call this on one thread, before the others.
  const LinearOperator& prepare(const std::string& method) { return h.bind(*make(method)).prepare(); }
  /// A solver of `method` set up on the prepared operator (safe on any thread after prepare()).
  std::unique_ptr<Solver> build(const std::string& method, const LinearOperator& op) {
    auto s = make(method);
    s->setup(op);
    return s;
  }
};

System& system_once() {
  static System s;
  return s;
}

/// Whether this build has the spec's method (the PETSc ones are registered without PETSc, and say
/// so).
bool available(const std::string& spec) {
  const std::string method = spec.substr(0, spec.find(' '));
  return solver_info(method).component != "petsc" || mg::petsc_available();
}

/// ||b - A x|| / ||b||.
double relative_residual(const LinearOperator& A, const Vector& b, const Vector& x) {
  Vector r;
  A.residual(b, x, r);
  return r.norm() / b.norm();
}

const std::vector<std::string> kMethods = {"cg", "block-jacobi-pcg", "mcg", "cholmod", "mgpcg",
                                           "mgpcg smoother.preconditioner=patch", "boomeramg-pcg", "gamg-pcg",
                                           "mumps", "petsc-cholmod"};

/// Runs `work(t)` on `n` threads at once and returns the messages of the exceptions they threw.
template <typename Work>
std::vector<std::string> on_threads(int n, Work work) {
  std::vector<std::string> errors(n);
  std::vector<std::thread> threads;
  std::atomic<int> ready{0};
  for (int t = 0; t < n; ++t)
    threads.emplace_back([&, t] {
      ++ready;
      while (ready < n) std::this_thread::yield();  // start together
      try {
        work(t);
      } catch (const std::exception& e) {
        errors[t] = e.what();
      }
    });
  for (auto& th : threads) th.join();
  return errors;
}

}  // namespace

TEST_CASE("solvers of their own on several threads at once give their answers alone", "[threads]") {
  System& sys = system_once();
  const LinearOperator& A = sys.h.matrix(sys.h.num_levels() - 1);
  for (const std::string& method : kMethods) {
    if (!available(method)) continue;
    SECTION(method) {
      const LinearOperator& op = sys.prepare(method);
      // Alone first: the reference answers.
      std::vector<Vector> reference(sys.rhs.size());
      {
        auto s = sys.build(method, op);
        for (size_t k = 0; k < sys.rhs.size(); ++k) s->solve(sys.rhs[k], reference[k]);
      }
      std::vector<std::vector<Vector>> got(4, std::vector<Vector>(sys.rhs.size()));
      const auto errors = on_threads(4, [&](int t) {
        auto s = sys.build(method, op);  // built, set up and used on this thread
        for (int round = 0; round < 3; ++round)
          for (size_t k = 0; k < sys.rhs.size(); ++k) {
            Vector x;
            s->solve(sys.rhs[k], x);
            got[t][k] = x;
          }
        s->update();
      });
      for (int t = 0; t < 4; ++t) {
        INFO(method << " thread " << t);
        CHECK(errors[t] == "");
        if (!errors[t].empty()) continue;
        for (size_t k = 0; k < sys.rhs.size(); ++k) {
          CHECK(relative_residual(A, sys.rhs[k], got[t][k]) < 1e-7);
          // the answer given alone, to round-off: inside a thread of its own OpenMP runs a team of
          // one (nested), so sums may run in another order; measured agreement 1e-10 or better
          CHECK((got[t][k] - reference[k]).norm() <= 1e-8 * reference[k].norm());
        }
      }
    }
  }
}

TEST_CASE("one solver shared by several threads serialises their calls and answers each", "[threads]") {
  System& sys = system_once();
  const LinearOperator& A = sys.h.matrix(sys.h.num_levels() - 1);
  for (const std::string& method : kMethods) {
    if (!available(method)) continue;
    SECTION(method) {
      auto s = sys.build(method, sys.prepare(method));
      std::vector<std::vector<Vector>> got(4, std::vector<Vector>(3));
      const auto errors = on_threads(4, [&](int t) {
        for (int round = 0; round < 3; ++round) {
          const Vector& b = sys.rhs[(t + round) % sys.rhs.size()];
          Vector x;
          s->solve(b, x);
          got[t][round] = x;
          if (t == 0 && round == 1) s->update();  // numeric set-up while the others solve
          Vector z;
          s->apply(b, z);  // as a preconditioner, interleaved with the others' solves
          if (!z.allFinite()) throw Error("apply gave NaN/Inf");
        }
      });
      for (int t = 0; t < 4; ++t) {
        INFO(method << " thread " << t);
        CHECK(errors[t] == "");
        if (!errors[t].empty()) continue;
        for (int round = 0; round < 3; ++round)
          CHECK(relative_residual(A, sys.rhs[(t + round) % sys.rhs.size()], got[t][round]) < 1e-7);
      }
    }
  }
}

TEST_CASE("the coarser meshes' cycle on several threads at once gives its answers alone", "[threads]") {
  // A refined bar: the Galerkin product, the patterns and the inner cycle of coarse_meshes=on,
  // built, set up, solved and updated on threads of their own (and, for the reference, on
  // OpenMP's team).
  std::vector<Refinement> record;
  const TetMesh mesh = refine_uniform(box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5), 1, &record);
  DegreeHierarchy h(mesh, 2, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; });
  h.set_refinements(record);
  h.assemble(nullptr);
  const Vector b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
  SolverContext ctx;
  ctx.levels = &h;
  auto make = [&] {
    auto s = make_solver(Config::from_pairs({"method=mgpcg", "coarse_meshes=on", "tol=1e-10"}, "test"), ctx);
    s->setup(h.matrix(h.num_levels() - 1));
    return s;
  };
  Vector reference;
  make()->solve(b, reference);
  std::vector<Vector> got(4);
  const auto errors = on_threads(4, [&](int t) {
    auto s = make();
    s->solve(b, got[t]);
    s->update();
    s->solve(b, got[t]);
  });
  for (int t = 0; t < 4; ++t) {
    INFO("thread " << t);
    CHECK(errors[t] == "");
    if (errors[t].empty()) CHECK((got[t] - reference).norm() <= 1e-8 * reference.norm());
  }
}

TEST_CASE("the matrix-free operator's force and diagonal blocks on the OpenMP threads: their one-thread values",
          "[threads]") {
  // Contiguous ranges of batches write the nodes only they hold in place and the shared ones into
  // their own slots (ElasticityOperator::element_force, diagonal_blocks): under ThreadSanitizer a
  // write two ranges make to one node is reported.
  const TetMesh mesh = box_mesh_24(8, 2, 2, 1.0, 0.25, 0.25);  // 768 tets: 48 batches
  ElasticityModel model(mesh, 3, Material{500e3, 0.3, 1000.0});
  model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
  Vector u(model.num_dofs());
  for (Eigen::Index i = 0; i < u.size(); ++i) u[i] = 1e-3 * std::sin(0.37 * static_cast<double>(i));
  const Rotations R = model.rotations(u);
  ElasticityOperator op(model);
  op.update(&R);
  op.set_weights(1.0, 1e-4);
  auto evaluate = [&](int threads) {
#ifdef _OPENMP
    const int before = omp_get_max_threads();
    omp_set_num_threads(threads);
#endif
    Vector f;
    double energy = 0.0;
    op.element_force(u, &R, f, &energy);
    std::vector<double> d;
    op.diagonal_blocks(d);
#ifdef _OPENMP
    omp_set_num_threads(before);
#endif
    return std::make_tuple(f, energy, d);
  };
  const auto [f1, e1, d1] = evaluate(1);
  const auto [f2, e2, d2] = evaluate(2);
  CHECK(f2 == f1);  // the same sums in the same order on any number of threads
  CHECK(e2 == e1);
  REQUIRE(d2.size() == d1.size());
  double err = 0.0, size = 0.0;
  for (size_t i = 0; i < d1.size(); ++i) err = std::max(err, std::abs(d2[i] - d1[i])), size = std::max(size, std::abs(d1[i]));
  CHECK(err <= 1e-12 * size);
  CHECK(f1.norm() > 0.0);
}
