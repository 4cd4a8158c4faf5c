#include "pmg/fem/generators.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

using namespace pmg;
using namespace pmg::fem;

namespace {
TetMesh single_tet() {
  TetMesh m;
  m.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  m.tets = {{0, 1, 2, 3}};
  return m;
}
}  // namespace

TEST_CASE("the 24-tet box mesh is conforming with positive volumes", "[fem][mesh]") {
  TetMesh m = box_mesh_24(5, 1, 1, 1.0, 0.2, 0.2);
  CHECK(m.num_tets() == 5 * 24);
  // corners 6*2*2, box centres 5, face centres: 5*4 lateral + 6 end faces
  CHECK(m.num_vertices() == 24 + 5 + 26);
  REQUIRE_NOTHROW(check_mesh(m));
  double volume = 0.0;
  for (index_t e = 0; e < m.num_tets(); ++e) volume += m.signed_volume(e);
  CHECK(volume == Approx(0.04));
  // The middle of the free end is a vertex.
  bool found = false;
  for (const Vec3& v : m.vertices) found |= (v - Vec3(1.0, 0.1, 0.1)).norm() < 1e-14;
  CHECK(found);
}

TEST_CASE("mesh errors name the element, vertex or face", "[fem][mesh][errors]") {
  SECTION("inverted element") {
    TetMesh m = single_tet();
    std::swap(m.tets[0][1], m.tets[0][2]);
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("element 0 is inverted"));
    MeshCheckOptions fix;
    fix.fix_orientation = true;
    check_mesh(m, fix);
    CHECK(m.signed_volume(0) > 0);
  }
  SECTION("zero-volume element") {
    TetMesh m = single_tet();
    m.vertices[3] = Vec3(0.5, 0.5, 0.0);
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("element 0 is degenerate"));
  }
  SECTION("vertex id out of range") {
    TetMesh m = single_tet();
    m.tets[0][2] = 7;
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("element 0 refers to vertex 7"));
  }
  SECTION("repeated vertex") {
    TetMesh m = single_tet();
    m.tets[0][3] = 0;
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("uses vertex 0 twice"));
  }
  SECTION("unused vertex") {
    TetMesh m = single_tet();
    m.vertices.push_back(Vec3(2, 2, 2));
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("vertex 4 belongs to no element"));
  }
  SECTION("non-finite coordinate") {
    TetMesh m = single_tet();
    m.vertices[1].x() = std::numeric_limits<double>::quiet_NaN();
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("vertex 1 has a non-finite coordinate"));
  }
  SECTION("duplicate element") {
    TetMesh m = single_tet();
    m.tets.push_back({0, 2, 3, 1});
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("element 1 duplicates element 0"));
  }
  SECTION("face shared by three elements") {
    TetMesh m = single_tet();
    m.vertices.push_back(Vec3(0.3, 0.3, -1.0));
    m.vertices.push_back(Vec3(0.2, 0.2, 0.8));
    m.tets.push_back({0, 2, 1, 4});
    m.tets.push_back({0, 1, 2, 5});  // overlaps element 0 through the same face
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("non-manifold"));
  }
  SECTION("empty mesh") {
    TetMesh m;
    CHECK_THROWS_WITH(check_mesh(m), Catch::Contains("no elements"));
  }
}
