#include "pmg/fem/generators.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>

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
  CHECK_THROWS_WITH(box_mesh_24(1, 1, 1, std::numeric_limits<double>::infinity(), 1, 1),
                    Catch::Contains("positive and finite"));
  CHECK_THROWS_WITH(box_mesh_24(1, 1, 1, 1e-320, 1, 1), Catch::Contains("too small"));
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

namespace {
/// Faces on the boundary (used by one element), as sorted vertex triples.
size_t boundary_faces(const TetMesh& m) {
  std::map<std::array<index_t, 3>, int> count;
  for (const Tet& t : m.tets)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<index_t, 3> f;
      for (int i = 0, k = 0; i < 4; ++i)
        if (i != skip) f[k++] = t[i];
      std::sort(f.begin(), f.end());
      ++count[f];
    }
  size_t n = 0;
  for (const auto& [f, c] : count) n += c == 1;
  return n;
}

/// Smallest of (6 √2 V) / (longest edge)³ over the elements: 1 for the regular tetrahedron.
double worst_shape(const TetMesh& m) {
  double worst = 1e300;
  for (index_t e = 0; e < m.num_tets(); ++e) {
    double longest = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        longest = std::max(longest, (m.vertices[m.tets[e][i]] - m.vertices[m.tets[e][j]]).norm());
    worst = std::min(worst, 6 * std::sqrt(2.0) * m.signed_volume(e) / std::pow(longest, 3));
  }
  return worst;
}
}  // namespace

TEST_CASE("uniform refinement splits each tet into 8 conforming tets of the same total volume", "[fem][mesh]") {
  for (const TetMesh& base : {single_tet(), box_mesh_24(2, 1, 1, 2.0, 1.0, 1.0)}) {
    double volume = 0.0;
    for (index_t e = 0; e < base.num_tets(); ++e) volume += base.signed_volume(e);
    TetMesh m = base;
    for (int level = 1; level <= 2; ++level) {
      const TetMesh fine = refine_uniform(m);
      // V + E vertices: count the edges of m.
      std::set<std::pair<index_t, index_t>> edges;
      for (const Tet& t : m.tets)
        for (int i = 0; i < 4; ++i)
          for (int j = i + 1; j < 4; ++j) edges.insert(std::minmax(t[i], t[j]));
      CHECK(fine.num_vertices() == m.num_vertices() + static_cast<index_t>(edges.size()));
      CHECK(fine.num_tets() == 8 * m.num_tets());
      double v = 0.0;
      for (index_t e = 0; e < fine.num_tets(); ++e) {
        CHECK(fine.signed_volume(e) > 0);
        v += fine.signed_volume(e);
      }
      CHECK(v == Approx(volume).epsilon(1e-12));
      // Conforming: every boundary face of m became exactly 4, and no face inside is unmatched.
      CHECK(boundary_faces(fine) == 4 * boundary_faces(m));
      TetMesh copy = fine;
      REQUIRE_NOTHROW(check_mesh(copy));
      // Shortest-diagonal splitting keeps the shapes: no worse than a third of the coarse worst.
      CHECK(worst_shape(fine) >= worst_shape(base) / 3.0);
      m = fine;
    }
    CHECK(refine_uniform(base, 2).num_tets() == m.num_tets());
  }
  CHECK_THROWS_AS(refine_uniform(single_tet(), -1), MeshError);
}

namespace {
/// The octahedron of four tets around the z axis (tests/tools/data/octahedron.*), 0-based.
TetMesh octahedron() {
  TetMesh m;
  m.vertices = {Vec3(0, 0, -1), Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(0, -1, 0)};
  m.tets = {{0, 1, 2, 3}, {0, 1, 3, 4}, {0, 1, 4, 5}, {0, 1, 5, 2}};
  return m;
}
}  // namespace

TEST_CASE("tangled and cracked meshes are named unless allowed", "[fem][mesh]") {
  MeshCheckOptions fix;
  fix.fix_orientation = true;
  SECTION("a sound mesh passes, in either orientation") {
    TetMesh m = octahedron();
    CHECK_NOTHROW(check_mesh(m, fix));
  }
  SECTION("a vertex pushed through a face: two elements on the same side of their face") {
    TetMesh m = octahedron();
    m.vertices[2] = Vec3(-0.5, 0, 0);
    CHECK_THROWS_WITH(check_mesh(m, fix), Catch::Contains("the mesh is tangled") &&
                                              Catch::Contains("lie on the same side of their shared face"));
    MeshCheckOptions allow = fix;
    allow.allow_tangled = true;
    TetMesh again = octahedron();
    again.vertices[2] = Vec3(-0.5, 0, 0);
    CHECK_NOTHROW(check_mesh(again, allow));
  }
  SECTION("coincident vertices: an unwelded seam") {
    TetMesh m = octahedron();
    m.vertices.push_back(m.vertices[0]);
    m.vertices.push_back(m.vertices[1]);
    m.tets[2] = {6, 7, 4, 5};
    m.tets[3] = {6, 7, 5, 2};
    CHECK_THROWS_WITH(check_mesh(m, fix), Catch::Contains("vertices 0 and 6 lie at the same point") &&
                                              Catch::Contains("cracked"));
    MeshCheckOptions allow = fix;
    allow.allow_cracked = true;
    CHECK_NOTHROW(check_mesh(m, allow));
  }
  SECTION("two tets touching along an edge only: a non-manifold boundary") {
    TetMesh m;
    m.vertices = {Vec3(0, 0, 0), Vec3(0, 0, 1), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(-1, 0, 0), Vec3(-1, -1, 0)};
    m.tets = {{0, 1, 2, 3}, {0, 1, 4, 5}};
    CHECK_THROWS_WITH(check_mesh(m, fix), Catch::Contains("boundary edge (0, 1) belongs to 4 boundary faces"));
  }
  SECTION("the generators and uniform refinement give sound meshes") {
    TetMesh box = box_mesh_24(3, 2, 1, 3.0, 2.0, 1.0);
    CHECK_NOTHROW(check_mesh(box));
    TetMesh fine = refine_uniform(octahedron(), 2);
    CHECK_NOTHROW(check_mesh(fine));
  }
}

TEST_CASE("reorder_for_locality keeps the mesh and puts its elements and vertices in Morton order",
          "[fem][mesh]") {
  // A box mesh shuffled (as a file's order can be), with a vertex no element uses.
  TetMesh shuffled = box_mesh_24(16, 2, 2, 8.0, 1.0, 1.0);
  std::mt19937 rng(7);
  std::shuffle(shuffled.tets.begin(), shuffled.tets.end(), rng);
  std::vector<index_t> vperm(shuffled.vertices.size());
  for (size_t i = 0; i < vperm.size(); ++i) vperm[i] = static_cast<index_t>(i);
  std::shuffle(vperm.begin(), vperm.end(), rng);
  TetMesh m;
  m.vertices.resize(vperm.size());
  for (size_t i = 0; i < vperm.size(); ++i) m.vertices[static_cast<size_t>(vperm[i])] = shuffled.vertices[i];
  for (const Tet& t : shuffled.tets) m.tets.push_back({vperm[t[0]], vperm[t[1]], vperm[t[2]], vperm[t[3]]});
  m.vertices.push_back(Vec3(100, 100, 100));

  const std::vector<index_t> order = morton_order(m);
  std::vector<index_t> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < sorted.size(); ++i) REQUIRE(sorted[i] == static_cast<index_t>(i));  // a permutation

  const TetMesh r = reorder_for_locality(m);
  REQUIRE(r.num_tets() == m.num_tets());
  REQUIRE(r.num_vertices() == m.num_vertices());
  CHECK(r.vertices.back() == Vec3(100, 100, 100));  // the unused vertex last
  // Element pos of r is element order[pos] of m: the same corners in the same order (orientation kept).
  index_t next = 0;
  for (index_t pos = 0; pos < r.num_tets(); ++pos) {
    const Tet& a = r.tets[static_cast<size_t>(pos)];
    const Tet& b = m.tets[static_cast<size_t>(order[static_cast<size_t>(pos)])];
    for (int i = 0; i < 4; ++i) {
      CHECK(r.vertices[a[i]] == m.vertices[b[i]]);
      if (a[i] >= next) {  // vertices numbered in the order the elements first meet them
        CHECK(a[i] == next);
        ++next;
      }
    }
    CHECK(r.signed_volume(pos) == m.signed_volume(order[static_cast<size_t>(pos)]));
  }
  // Already in order: the reordered mesh's Morton order is its own.
  const std::vector<index_t> again = morton_order(r);
  for (size_t pos = 0; pos < again.size(); ++pos) REQUIRE(again[pos] == static_cast<index_t>(pos));
  CHECK(reorder_for_locality(r).tets == r.tets);
}
