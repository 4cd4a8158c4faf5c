#include "pmg/fem/generators.hpp"
#include "pmg/fem/element.hpp"

#include <catch2/catch.hpp>

#include <random>
#include <set>

using namespace pmg;
using namespace pmg::fem;

TEST_CASE("BB node counts are V, V+E, V+2E+F", "[fem][bb]") {
  const TetMesh m = box_mesh_24(2, 2, 1, 1.0, 1.0, 0.5);
  const BBSpace s1(m, 1), s2(m, 2), s3(m, 3);
  const index_t V = m.num_vertices(), E = s2.num_edges(), F = s3.num_faces();
  CHECK(s1.num_nodes() == V);
  CHECK(s2.num_nodes() == V + E);
  CHECK(s3.num_nodes() == V + 2 * E + F);
  // Euler for a ball: V - E + F - T = 1
  CHECK(V - E + F - m.num_tets() == 1);
  CHECK(s3.nodes_per_element() == 20);
}

TEST_CASE("neighbouring elements share their BB nodes at the same positions", "[fem][bb]") {
  const TetMesh m = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
  for (int p = 1; p <= 3; ++p) {
    const BBSpace s(m, p);
    const auto& alpha = multi_indices(p);
    std::vector<int> uses(s.num_nodes(), 0);
    for (index_t e = 0; e < m.num_tets(); ++e)
      for (int a = 0; a < s.nodes_per_element(); ++a) {
        Vec3 X = Vec3::Zero();
        for (int i = 0; i < 4; ++i) X += (alpha[a][i] / double(p)) * m.vertices[m.tets[e][i]];
        CHECK((s.positions()[s.node(e, a)] - X).norm() < 1e-14);
        ++uses[s.node(e, a)];
      }
    // No two nodes at one position, and every node used.
    std::set<std::array<long, 3>> where;
    for (const Vec3& X : s.positions()) where.insert({std::lround(X.x() * 1e9), std::lround(X.y() * 1e9), std::lround(X.z() * 1e9)});
    CHECK(where.size() == static_cast<size_t>(s.num_nodes()));
    for (int u : uses) CHECK(u > 0);
  }
}

TEST_CASE("Bernstein polynomials are a nonnegative partition of unity", "[fem][bb]") {
  std::mt19937 gen(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int p = 1; p <= 3; ++p)
    for (int trial = 0; trial < 20; ++trial) {
      Eigen::Vector4d l(u(gen), u(gen), u(gen), u(gen));
      l /= l.sum();
      double sum = 0.0;
      Eigen::Vector4d gsum = Eigen::Vector4d::Zero();
      for (const auto& a : multi_indices(p)) {
        const double b = bernstein(a, l);
        CHECK(b >= 0.0);
        sum += b;
        gsum += bernstein_gradient(a, l);
      }
      CHECK(sum == Approx(1.0).epsilon(1e-14));
      // Σ B_a = (Σ λ)^p: its λ-gradient is p (Σλ)^(p-1) in every component.
      for (int k = 0; k < 4; ++k) CHECK(gsum[k] == Approx(p).epsilon(1e-13));
    }
  CHECK(local_index({1, 1, 1, 0}) == 16);
  CHECK(num_element_nodes(3) == 20);
}
