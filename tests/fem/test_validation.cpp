// The seed's validation cases (docs/method.md §5, Tables 2.6 and 2.7). The small meshes run with the suite;
// the refined ones are tagged [.validation] and run with `ctest -L validation`.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/static_solve.hpp"

#include <catch2/catch.hpp>

#include <cstdio>

using namespace pmg;
using namespace pmg::fem;

namespace {

// Cantilever 1.0 x 0.2 x 0.2 m, E = 500 kPa, ν = 0.3, fixed at x = 0, 10 N downwards at the free end.
constexpr double kReference = 0.05087;  // converged 3-D deflection of the end-face centre (docs/method.md §5)
const Vec3 kTip(1.0, 0.1, 0.1);

struct Deflections {
  double point, traction;
};

Deflections cantilever(index_t k, int p) {
  const TetMesh m = box_mesh_24(5 * k, k, k, 1.0, 0.2, 0.2);
  ElasticityModel model(m, p, Material{500e3, 0.3, 1000.0});
  model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
  Vector point = Vector::Zero(model.num_dofs()), traction = point;
  model.add_point_force(point, kTip, Vec3(0, 0, -10.0));
  const double area = model.add_traction(traction, [](const Vec3& X) { return X.x() > 1.0 - 1e-12; },
                                         Vec3(0, 0, -10.0 / 0.04));
  REQUIRE(area == Approx(0.04));
  return {-model.displacement_at(solve_static(model, point, false).u, kTip).z(),
          -model.displacement_at(solve_static(model, traction, false).u, kTip).z()};
}

// Bar under gravity: the cantilever's bar, fixed at x = 0, g = 9.81 m/s² downwards. The seed gives
// no density; ρ = 3200 kg/m³ makes the 4x1x1 linear centre line match its 2.62 m.
struct Lengths {
  double linear, corotational;
  int iterations;
};

double centre_line_length(const ElasticityModel& model, const Vector& u) {
  double length = 0.0;
  Vec3 previous;
  const int samples = 400;
  for (int i = 0; i <= samples; ++i) {
    const Vec3 X(static_cast<double>(i) / samples, 0.1, 0.1);
    const Vec3 x = X + model.displacement_at(u, X);
    if (i) length += (x - previous).norm();
    previous = x;
  }
  return length;
}

Lengths gravity_bar(index_t k) {
  const TetMesh m = box_mesh_24(4 * k, k, k, 1.0, 0.2, 0.2);
  ElasticityModel model(m, 3, Material{500e3, 0.3, 3200.0});
  model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
  const Vector g = model.gravity(Vec3(0, 0, -9.81));
  const StaticResult lin = solve_static(model, g, false);
  const StaticResult co = solve_static(model, g, true);
  return {centre_line_length(model, lin.u), centre_line_length(model, co.u), co.iterations};
}

}  // namespace

TEST_CASE("Table 2.6: cantilever deflection converges with the degree", "[fem][table2.6]") {
  std::printf("Table 2.6, 5x1x1 cubes: degree, point-load deflection (seed 0.03/0.048/0.05), "
              "traction deflection (reference %.5f)\n", kReference);
  double previous = 0.0;
  for (int p = 1; p <= 3; ++p) {
    const Deflections d = cantilever(1, p);
    std::printf("  p=%d  point %.5f m  traction %.5f m (%+.2f%%)\n", p, d.point, d.traction,
                100.0 * (d.traction - kReference) / kReference);
    CHECK(d.traction > previous);  // converges from below (the discrete model is too stiff)
    previous = d.traction;
    if (p == 3) CHECK(std::abs(d.traction - kReference) <= 0.005 * kReference);
  }
}

TEST_CASE("Table 2.6 refined: cubic traction deflection within 0.05% on 20x4x4",
          "[.validation][table2.6]") {
  const Deflections d = cantilever(4, 3);
  std::printf("20x4x4 cubes, p=3: point %.5f m, traction %.6f m (%+.3f%% from %.5f)\n", d.point,
              d.traction, 100.0 * (d.traction - kReference) / kReference, kReference);
  CHECK(std::abs(d.traction - kReference) <= 0.0005 * kReference);
}

TEST_CASE("Table 2.7: under gravity the corotational bar keeps its length, the linear one grows",
          "[fem][table2.7]") {
  const Lengths l = gravity_bar(1);
  std::printf("Table 2.7, 4x1x1 cubes, cubic: centre line linear %.3f m (seed 2.62), corotational "
              "%.3f m (seed 1.04), %d fixed-point iterations\n",
              l.linear, l.corotational, l.iterations);
  CHECK(l.linear > 2.0);
  CHECK(l.corotational > 1.0);
  CHECK(l.corotational < 1.05);
}

TEST_CASE("Table 2.7 refined: 8x2x2 and 16x4x4 cubes", "[.validation][table2.7]") {
  for (index_t k : {2, 4}) {
    const Lengths l = gravity_bar(k);
    std::printf("Table 2.7, %dx%dx%d cubes, cubic: linear %.3f m, corotational %.3f m (%d "
                "iterations)\n", 4 * k, k, k, l.linear, l.corotational, l.iterations);
    CHECK(l.linear > 2.0);
    CHECK(l.corotational > 1.0);
    CHECK(l.corotational < 1.05);
  }
}
