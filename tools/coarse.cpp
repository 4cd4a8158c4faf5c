// pmg coarse — the seed's Table 2.8: geometric (re-discretised) against Galerkin (R A P) coarse
// operators, each with R = Pᵀ and with the seed's interpolating restriction.
//
//   1. Build the scene and a corotational state: the rotations of the linear static solution under
//      the scene's load (so the update really rotates every element).
//   2. For each variant, time the update of the lower levels for new rotations (geometric:
//      re-assemble them with the same rotations; Galerkin: two sparse products per level), the
//      time of one cycle, and the cycles needed to reduce the residual by 1e2 ... 1e5.
#include "checks.hpp"
#include "commands.hpp"
#include "scene.hpp"
#include "table.hpp"

#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/sparse/timer.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>

namespace pmg::tools {

namespace {


struct CoarseOptions {
  SceneOptions scene;
  int repeats = 5;
};

void run(const CoarseOptions& o) {
  FemSystem sys = build_fem_system(o.scene);
  fem::DegreeHierarchy& h = sys.hierarchy();
  if (h.num_levels() < 2) throw InputError("pmg coarse needs degree >= 2");
  const fem::ElasticityModel& fine = h.finest();
  // Rotations of the deformed state under the load (linear static solution).
  Vector f = fine.expand(sys.b, Vector());
  const fem::Rotations R = fine.rotations(fem::solve_static(fine, f, false).u);
  Vector rhs = sys.b;
  h.assemble(&R, nullptr, sys.mass_weight, sys.stiffness_weight);
  std::cout << "scene: " << sys.description << "\n"
            << "system: " << sys.b.size() << " unknowns; rotations from the linear static solution; "
            << count_of(omp_get_max_threads(), "thread") << "\n\n";

  Table t({"coarse operator", "restriction", "update [ms]", "cycle [ms]", "1e2", "1e3", "1e4", "1e5"});
  for (const bool galerkin : {false, true})
    for (const bool interpolating : {false, true}) {
      const Config config = Config::from_pairs(
          // The seed's Table 2.8: both coarse operators under the assembled Gauss–Seidel cycle.
          {"method=pmg", "operator=assembled",
           std::string("coarse_operator=") + (galerkin ? "galerkin" : "geometric"),
           std::string("restriction=") + (interpolating ? "interpolating" : "transpose")},
          "pmg coarse");
      SolverContext ctx;
      ctx.levels = &h;
      const auto solver = mg::make_cycle(config, ctx);
      mg::MultigridCycle& cycle = *solver;
      cycle.setup(h.matrix(h.num_levels() - 1));
      // Update of the lower levels for new rotations (the finest level is common to both).
      double update = 1e300;
      for (int r = 0; r < o.repeats; ++r) {
        const auto t0 = Clock::now();
        if (galerkin) {
          cycle.refresh_galerkin();
        } else {
          for (int l = 0; l + 1 < h.num_levels(); ++l)
            h.assemble_level(l, &R, nullptr, sys.mass_weight, sys.stiffness_weight);
        }
        update = std::min(update, seconds_since(t0));
      }
      cycle.update();
      // Cycles to reduce the residual by 1e2..1e5.
      const Bcsr& A = sys.matrix();
      Vector x = Vector::Zero(sys.b.size()), r;
      const double r0 = sys.b.norm();
      int reached[4] = {-1, -1, -1, -1};
      const auto t0 = Clock::now();
      int cycles = 0;
      for (; cycles < 500 && reached[3] < 0; ++cycles) {
        cycle.cycle(sys.b, x);
        A.residual(sys.b, x, r);
        const double rel = r.norm() / r0;
        if (!std::isfinite(rel)) throw SolveError({SolveStatus::non_finite, cycles, rel, rel, 0, "PMG: residual became NaN"});
        for (int k = 0; k < 4; ++k)
          if (reached[k] < 0 && rel <= std::pow(10.0, -2 - k)) reached[k] = cycles + 1;
      }
      const double cycle_ms = 1e3 * seconds_since(t0) / cycles;
      auto cell = [](int c) { return c < 0 ? std::string(">500") : std::to_string(c); };
      t.add({galerkin ? "Galerkin" : "geometric", interpolating ? "interpolating (seed)" : "P^T",
             fmt("%.2f", 1e3 * update), fmt("%.2f", cycle_ms), cell(reached[0]), cell(reached[1]),
             cell(reached[2]), cell(reached[3])});
    }
  t.print(std::cout);
  std::cout << "\nupdate: lower levels for new rotations, best of " << o.repeats
            << "; cycle: V-cycle with " << 5 << "+5 block Gauss-Seidel sweeps, residual included\n";
}

}  // namespace

void register_coarse(CLI::App& app) {
  auto o = std::make_shared<CoarseOptions>();
  o->scene.box = {4, 1, 1};
  CLI::App* sub = app.add_subcommand(
      "coarse", "Geometric vs Galerkin coarse operators with both restrictions (the seed's Table 2.8)");
  add_scene_options(sub, o->scene);
  sub->add_option("--repeats", o->repeats, "timing repeats of the update (best is reported)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  add_threads_option(sub);
  sub->callback([o] { run(*o); });
}

}  // namespace pmg::tools
