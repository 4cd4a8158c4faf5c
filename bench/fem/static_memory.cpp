// Peak memory and time of one static cubic solve, assembled or matrix-free, in a process of its
// own (peak RSS is per process: run the two routes as two commands).
//
//   static_memory assembled|matrix-free [--pmg_boxes=8] [--pmg_degree=3] [--pmg_tol=1e-6]
//
// The system: a unit cube of n^3 boxes of 24 tetrahedra, clamped at z = 0, under gravity; solved
// from zero by MGPCG (the factory's defaults, with operator=assembled or matrix-free). The
// assembled route assembles every level; the matrix-free one assembles the linear level only.
// Prints unknowns, set-up and solve seconds, iterations, the true relative residual (of the
// assembled matrix for the assembled route, of the operator for the matrix-free one) and the peak
// resident set size (getrusage) — the figure docs/performance.md compares.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/sparse/timer.hpp"

#include "../bandwidth.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {
double peak_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;  // kilobytes on Linux
}
}  // namespace

int main(int argc, char** argv) {
  using namespace pmg;
  int boxes = 8, degree = 3;
  double tol = 1e-6;
  std::string route;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (bench::integer_flag(a, "pmg_boxes", boxes) || bench::integer_flag(a, "pmg_degree", degree, 2)) continue;
    if (a.rfind("--pmg_tol=", 0) == 0) {
      char* end = nullptr;
      tol = std::strtod(a.c_str() + 10, &end);
      if (*end != '\0' || !(tol > 0 && tol < 1)) {
        std::fprintf(stderr, "--pmg_tol: expected a number in (0, 1), got '%s'\n", a.c_str() + 10);
        return 2;
      }
    } else if (route.empty() && (a == "assembled" || a == "matrix-free")) {
      route = a;
    } else {
      std::fprintf(stderr, "static_memory: unknown argument '%s'\nusage: static_memory assembled|matrix-free "
                           "[--pmg_boxes=8] [--pmg_degree=3] [--pmg_tol=1e-6]\n", a.c_str());
      return 2;
    }
  }
  if (route.empty() || degree > 3) {
    std::fprintf(stderr, "usage: static_memory assembled|matrix-free [--pmg_boxes=8] [--pmg_degree=2|3] [--pmg_tol=1e-6]\n");
    return 2;
  }
  try {
    const bool mf = route == "matrix-free";
    const auto t0 = std::chrono::steady_clock::now();
    const fem::TetMesh mesh = fem::box_mesh_24(boxes, boxes, boxes, 1.0, 1.0, 1.0);
    fem::DegreeHierarchy h(mesh, degree, fem::Material{1e6, 0.3, 1000.0},
                           [](const fem::Vec3& X) { return X.z() < 1e-12; });
    const int L = h.num_levels();
    const Vector b = h.finest().restrict_to_free(h.finest().gravity(fem::Vec3(0, 0, -9.81)));
    if (mf) {
      h.assemble_level(0, nullptr);
      for (int l = 1; l < L; ++l) h.update_matrix_free(l, nullptr);
    } else {
      h.assemble(nullptr);
    }
    const LinearOperator& A = mf ? *h.matrix_free_operator(L - 1) : static_cast<const LinearOperator&>(h.matrix(L - 1));
    SolverContext ctx;
    ctx.levels = &h;
    mg::register_solvers();
    auto solver = make_solver(Config::from_pairs({"method=mgpcg", "tol=" + std::to_string(tol), "operator=" + route},
                                                 "static_memory"),
                              ctx);
    solver->setup(A);
    const double setup = seconds_since(t0);
    Vector x = Vector::Zero(b.size());
    const auto t1 = std::chrono::steady_clock::now();
    const SolveResult res = solver->solve(b, x);
    const double solve = seconds_since(t1);
    Vector r;
    A.residual(b, x, r);
    std::printf("%s: degree %d, %ld unknowns, set-up (mesh, levels, solver) %.3f s, solve %.3f s, %d "
                "iterations, true relative residual %.2e, peak RSS %.1f MiB\n",
                route.c_str(), degree, static_cast<long>(b.size()), setup, solve, res.iterations,
                r.norm() / b.norm(), peak_rss_mib());
    return res.ok() ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "static_memory: %s\n", e.what());
    return 1;
  }
}
