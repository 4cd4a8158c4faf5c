// Writes a deformed degree-p mesh as .vtu (deformed geometry + displacement) and, for a real VTK
// reader to check, samples.csv: cell, VTK parametric coordinates (r, s, t), and the deformed
// position and displacement pmgkit computes there.   vtu_sample DIR P
#include "pmg/fem/elasticity.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/fem/vtk_writer.hpp"

#include <cmath>
#include <fstream>
#include <random>

using namespace pmg;
using namespace pmg::fem;

int main(int argc, char** argv) {
  if (argc != 3) return 2;
  const std::string dir = argv[1];
  const int p = std::atoi(argv[2]);
  const TetMesh m = box_mesh_24(2, 1, 1, 1.0, 0.4, 0.3);
  const ElasticityModel model(m, p, Material{});
  const Vector u = model.interpolate([](const Vec3& X) {
    return Vec3(0.1 * std::sin(3 * X.y()) * X.x(), 0.05 * X.x() * X.x(), -0.2 * X.x() * X.x() * X.x());
  });
  VtuOptions opt;
  opt.deformed = true;
  write_vtu(dir + "/sample.vtu", model.space(), u, opt);
  write_vtu(dir + "/rest.vtu", model.space(), Vector::Zero(u.size()));
  write_pvd(dir + "/series.pvd", {{0.0, "rest.vtu"}, {0.5, "sample.vtu"}});
  std::ofstream csv(dir + "/samples.csv");
  csv.precision(17);
  std::mt19937 gen(1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (index_t e = 0; e < m.num_tets(); e += 5) {
    Eigen::Vector4d l(unit(gen), unit(gen), unit(gen), unit(gen));
    l /= l.sum();
    Vec3 X = Vec3::Zero();
    for (int i = 0; i < 4; ++i) X += l[i] * m.vertices[m.tets[e][i]];
    const Vec3 d = model.displacement_at(u, X);
    const Vec3 x = X + d;
    // VTK's tetra: vertex 0 at r=s=t=0, vertex 1 at r=1, vertex 2 at s=1, vertex 3 at t=1.
    csv << e << "," << l[1] << "," << l[2] << "," << l[3] << "," << x.x() << "," << x.y() << ","
        << x.z() << "," << d.x() << "," << d.y() << "," << d.z() << "\n";
  }
  return 0;
}
