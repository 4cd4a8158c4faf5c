// A project of your own using an installed pmgkit:
//  1. hands pmgkit a matrix of its own (an Eigen sparse matrix: the 1-D Laplacian) and solves it
//     with Jacobi-preconditioned CG and with CHOLMOD, which must agree;
//  2. solves the seed's cantilever with cubic Bernstein–Bézier elements;
//  3. runs three steps of a scene given as JSON text through pmg::sim.
#include <pmg/fem/generators.hpp>
#include <pmg/fem/static_solve.hpp>
#include <pmg/sim/run.hpp>
#include <pmg/solvers.hpp>
#include <pmg/cholmod/cholmod_solver.hpp>
#include <pmg/sparse/krylov.hpp>

#include <cmath>
#include <iostream>

int main() {
  pmg::register_all_solvers();  // the factory's methods: solve_static's default (CHOLMOD) among them
  const int n = 100;
  Eigen::SparseMatrix<double> L(n, n);
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0);
    if (i > 0) t.emplace_back(i, i - 1, -1.0);
    if (i + 1 < n) t.emplace_back(i, i + 1, -1.0);
  }
  L.setFromTriplets(t.begin(), t.end());

  const pmg::Csr A = pmg::Csr::from_eigen(L);
  const pmg::Vector b = pmg::Vector::Ones(n);
  pmg::Vector x_cg = pmg::Vector::Zero(n), x_chol;
  pmg::KrylovParams params;
  params.rel_tol = 1e-12;
  const pmg::JacobiPreconditioner M(A);
  const pmg::SolveResult r = pmg::pcg(A, &M, b, x_cg, params);
  pmg::CholmodSolver chol;  // any pmg::Solver: setup(A), then solve(b, x) or apply(b, x)
  chol.setup(A);
  chol.solve(b, x_chol);
  const double diff = (x_cg - x_chol).norm() / x_chol.norm();
  std::cout << "PCG: " << pmg::to_string(r.status) << " in " << r.iterations
            << " iterations; |x_pcg - x_cholmod| / |x_cholmod| = " << diff << "\n";

  using namespace pmg::fem;
  const TetMesh mesh = box_mesh_24(5, 1, 1, 1.0, 0.2, 0.2);
  ElasticityModel model(mesh, 3, Material{500e3, 0.3, 1000.0});
  model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
  pmg::Vector f = pmg::Vector::Zero(model.num_dofs());
  model.add_traction(f, [](const Vec3& X) { return X.x() > 1 - 1e-12; }, Vec3(0, 0, -250.0));
  const StaticResult s = solve_static(model, f, false);
  const double tip = model.displacement_at(s.u, Vec3(1.0, 0.1, 0.1)).z();
  std::cout << "cubic cantilever, end-face centre: " << tip << " m (converged 3-D: -0.05087)\n";

  const pmg::sim::Scene scene = pmg::sim::parse_scene(
      R"({"mesh": {"box": [2, 1, 1], "size": [2, 1, 1]}, "degree": 2,
          "initial": {"state": "twisted", "degrees": 10}, "time": {"dt": 0.01, "duration": 0.03}})",
      "consumer scene");
  pmg::sim::SceneSetup setup = pmg::sim::set_up(scene);
  pmg::sim::DynamicRun run(scene, setup, "");  // no output directory: nothing written
  const pmg::sim::RunSummary sum = run.run();
  std::cout << "scene: " << sum.steps_done << " steps, " << static_cast<double>(sum.iterations) / sum.steps_done
            << " " << run.method() << " cycles per step, energy " << sum.energy_initial << " -> "
            << sum.energy_final << " J\n";
  const bool scene_ok = sum.failed_step == 0 && sum.steps_done == 3 && sum.energy_final < sum.energy_initial;
  return diff < 1e-9 && std::abs(tip + 0.05087) < 0.005 * 0.05087 && scene_ok ? 0 : 1;
}
