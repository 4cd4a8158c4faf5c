// Cook's membrane in 3-D, nearly incompressible: mixed (Taylor–Hood) against displacement-only BB
// elements. The tapered panel with corners (0, 0), (48, 44), (48, 60), (0, 44), one layer of
// thickness 1 with every z component held (plane strain, exactly), clamped at x = 0, under a
// uniform vertical shear traction on x = 48 of total force 100 (6.25 per unit area); E = 250. The
// panel is n x n cells of 6 Kuhn tetrahedra (or, with --cells-kind box24, of 24: box_mesh_24), on
// the unit square mapped bilinearly onto the trapezoid (straight edges, conforming). Printed: the vertical displacement of the top corner
// C = (48, 60) for each degree, formulation and n, and its difference from a reference, the mixed
// cubic elements on the finest mesh given (no published value for this setting is used). Not a
// timing benchmark: a table for docs/robustness.md.
//
//   bench/fem/cook_membrane [--degrees 2,3] [--cells 2,4,8,16] [--nu 0.4999] [--reference-cells 32]
//                           [--cells-kind kuhn|box24]
#include "../../tests/fem/mixed_mms.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/fem/mixed.hpp"
#include "pmg/fem/static_solve.hpp"
#include "table_cli.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/sparse/config.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace {

using namespace pmg;
using namespace pmg::fem;

bool g_kuhn = true;  ///< --cells-kind: kuhn (the default) or box24

/// The panel: the unit square's n x n x 1 cells, (ξ, η) -> (48 ξ, 44 ξ + η (44 + 16 ξ - 44 ξ)).
TetMesh cook_mesh(int n) {
  TetMesh mesh = g_kuhn ? test::kuhn_grid(n, n, 1) : box_mesh_24(n, n, 1, 1.0, 1.0, 1.0);
  for (Vec3& v : mesh.vertices) {
    const double xi = v.x(), eta = v.y();
    v = Vec3(48.0 * xi, 44.0 * xi + eta * (44.0 + 16.0 * xi - 44.0 * xi), v.z());
  }
  return mesh;
}

std::vector<char> clamp(const TetMesh& mesh) {
  std::vector<char> c(mesh.vertices.size());
  for (size_t v = 0; v < c.size(); ++v) c[v] = mesh.vertices[v].x() < 1e-9;
  return c;
}

/// Every vertex's z component held: plane strain.
std::vector<char> plane_strain(const TetMesh& mesh) { return std::vector<char>(mesh.vertices.size(), 4); }

Vector shear_load(const ElasticityModel& model) {
  Vector f = Vector::Zero(model.num_dofs());
  const double area = model.add_traction(f, [](const Vec3& X) { return X.x() > 48.0 - 1e-9; }, Vec3(0, 6.25, 0));
  if (std::abs(area - 16.0) > 1e-9) throw Error("Cook's membrane: the loaded face has area " + std::to_string(area));
  return f;
}

struct Answer {
  double uy = 0.0;
  long unknowns = 0;
  int iterations = 0;
};

const Vec3 kCorner(48.0, 60.0, 0.0);

Answer mixed(int n, int k, double nu) {
  const TetMesh mesh = cook_mesh(n);
  MixedElasticity m(mesh, k, Material{250.0, nu, 1.0}, clamp(mesh), plane_strain(mesh));
  const Vector f = shear_load(m.hierarchy().finest());
  const MixedResult r = solve_mixed_static(m, f, Config::from_pairs({"method=mixed-minres", "tol=1e-10"}, "cook"));
  return {m.hierarchy().finest().displacement_at(r.u, kCorner).y(), static_cast<long>(m.num_unknowns()),
          r.solve.iterations};
}

Answer displacement(int n, int k, double nu) {
  const TetMesh mesh = cook_mesh(n);
  ElasticityModel model(mesh, k, Material{250.0, nu, 1.0});
  model.fix_vertices(clamp(mesh));
  model.constrain_components(plane_strain(mesh));
  const StaticResult r = solve_static(model, shear_load(model), false);
  return {model.displacement_at(r.u, kCorner).y(), static_cast<long>(model.num_free_dofs()), r.solver_iterations};
}

int run(int argc, char** argv) {
  std::vector<double> degrees{2, 3}, cells{2, 4, 8, 16}, nus{0.4999};
  int reference_cells = 32;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--degrees")) degrees = parse_list(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--cells")) cells = parse_list(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--nu")) nus = parse_list(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--reference-cells")) reference_cells = std::stoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--cells-kind") && (!std::strcmp(argv[i + 1], "kuhn") || !std::strcmp(argv[i + 1], "box24")))
      g_kuhn = !std::strcmp(argv[i + 1], "kuhn");
    else {
      std::fprintf(stderr, "unknown option %s (--degrees, --cells, --nu, --reference-cells, --cells-kind kuhn|box24)\n",
                   argv[i]);
      return 2;
    }
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // each row as it is done
  mg::register_solvers();
  for (double nu : nus) {
    const double ref = mixed(reference_cells, 3, nu).uy;
    std::printf("Cook's membrane, plane strain, E = 250, nu = %g, %s cells: reference u_y(C) = %.6f (mixed k = 3, n = %d)\n",
                nu, g_kuhn ? "6-tet Kuhn" : "24-tet box", ref, reference_cells);
    std::printf("%-3s %-5s | %-10s %-10s %-10s | %-10s %-10s %-10s\n", "k", "n", "mixed", "u_y(C)", "|diff|",
                "disp-only", "u_y(C)", "|diff|");
    for (double kd : degrees)
      for (double nd : cells) {
        const int k = static_cast<int>(kd), n = static_cast<int>(nd);
        const Answer a = mixed(n, k, nu), b = displacement(n, k, nu);
        std::printf("%-3d %-5d | %-10ld %-10.6f %-10.2e | %-10ld %-10.6f %-10.2e\n", k, n, a.unknowns, a.uy,
                    std::abs(a.uy - ref), b.unknowns, b.uy, std::abs(b.uy - ref));
      }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run_reporting_errors(run, argc, argv); }
