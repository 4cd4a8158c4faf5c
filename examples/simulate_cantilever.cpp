// A cubic cantilever sagging under gravity, simulated with the library alone (the
// simulation snippet of docs/library.md): implicit Euler, each step solved by PMG to 1e-3 with a warm start.
#include <pmg/fem/generators.hpp>
#include <pmg/fem/simulation.hpp>
#include <pmg/multigrid/factory.hpp>

#include <cstdio>

int main() {
  pmg::mg::register_solvers();  // pmg, mgpcg and the smoothers (or pmg::register_all_solvers())
  pmg::fem::TetMesh mesh = pmg::fem::box_mesh_24(4, 1, 1, 4.0, 1.0, 1.0);
  pmg::fem::DegreeHierarchy h(mesh, 3, {5e6, 0.3, 1000.0},  // E, nu, rho
                              [](const pmg::fem::Vec3& X) { return X.x() < 1e-9; });  // clamp
  auto solver = pmg::make_solver(  // PMG to 1e-3 per step, with a rounding floor for warm starts
      pmg::Config::from_pairs({"method=pmg", "tol=1e-3", "rhs_floor=1e-12"}, "example"), {&h});
  pmg::fem::ImplicitEuler sim(h, *solver, h.finest().gravity({0, 0, -9.81}), {/*dt*/ 0.01});
  int cycles = 0;
  for (int n = 0; n < 50; ++n) cycles += sim.step().iterations;  // throws on a failed solve
  const pmg::fem::Vec3 tip = h.finest().displacement_at(sim.displacement(), {4.0, 0.5, 0.5});
  std::printf("t = %.2f s: tip displacement (%.4f, %.4f, %.4f) m, %.1f cycles per step, energy %.3f J\n",
              sim.time(), tip.x(), tip.y(), tip.z(), cycles / 50.0, sim.total_energy());
  // The tip falls under gravity from rest: it must have moved down, and no energy is created.
  return tip.z() < 0 && sim.total_energy() <= 0 ? 0 : 1;
}
