#include "pmg/fem/generators.hpp"
#include "pmg/fem/mesh_io.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <unistd.h>

using namespace pmg;
using namespace pmg::fem;

namespace {
struct TempDir {
  std::filesystem::path path = std::filesystem::temp_directory_path() /
                               ("pmg_mesh_io_" + std::to_string(::getpid()));
  TempDir() { std::filesystem::create_directories(path); }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path / name) << text;
    return (path / name).string();
  }
};

// Two tetrahedra sharing a face, plus a surface triangle and a node no tet uses (tag 9).
const char* kMsh22 = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Comments
anything here is skipped
$EndComments
$Nodes
6
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
5 1 1 1
9 5 5 5
$EndNodes
$Elements
3
1 2 2 0 1 1 2 3
2 4 2 0 1 1 2 3 4
3 4 2 0 1 2 3 4 5
$EndElements
)";

const char* kMsh41 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Nodes
2 5 1 5
3 1 0 3
1
2
3
0 0 0
1 0 0
0 1 0
3 2 0 2
4
5
0 0 1
1 1 1
$EndNodes
$Elements
2 3 1 3
2 1 2 1
1 1 2 3
3 1 4 2
2 1 2 3 4
3 3 2 4 5
$EndElements
)";
}  // namespace

TEST_CASE("Gmsh 2.2 and 4.1 files give the same two tetrahedra", "[fem][mesh_io]") {
  TempDir d;
  std::vector<std::string> warnings;
  const TetMesh a = read_gmsh(d.write("a.msh", kMsh22), &warnings);
  const TetMesh b = read_mesh(d.write("b.msh", kMsh41));
  CHECK(a.num_tets() == 2);
  CHECK(a.num_vertices() == 5);  // node 9 dropped
  CHECK(warnings.size() == 1);
  CHECK(b.num_tets() == 2);
  CHECK(b.num_vertices() == 5);
  for (index_t e = 0; e < 2; ++e) {
    CHECK(a.signed_volume(e) > 0);  // the second tet is given inverted and is reoriented
    CHECK(a.signed_volume(e) == Approx(b.signed_volume(e)));
  }
}

TEST_CASE("TetGen .node/.ele round trip", "[fem][mesh_io]") {
  TempDir d;
  const TetMesh m = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
  write_tetgen((d.path / "bar").string(), m);
  const TetMesh r = read_mesh((d.path / "bar.ele").string());
  REQUIRE(r.num_tets() == m.num_tets());
  REQUIRE(r.num_vertices() == m.num_vertices());
  for (index_t v = 0; v < m.num_vertices(); ++v) CHECK(r.vertices[v] == m.vertices[v]);
}

TEST_CASE("malformed mesh files name the line", "[fem][mesh_io][errors]") {
  TempDir d;
  std::string bad = kMsh22;
  bad.replace(bad.find("3 0 1 0"), 7, "3 0 x 0");
  CHECK_THROWS_WITH(read_gmsh(d.write("bad1.msh", bad)), Catch::Contains("bad1.msh:11: expected a real value, found 'x'"));
  bad = kMsh22;
  bad.replace(bad.find("2 4 2 0 1 1 2 3 4"), 17, "2 4 2 0 1 1 2 3 7");
  CHECK_THROWS_WITH(read_gmsh(d.write("bad2.msh", bad)), Catch::Contains("refers to node 7, which is not defined"));
  bad = kMsh22;
  bad.replace(bad.find("2.2 0 8"), 7, "2.2 1 8");
  CHECK_THROWS_WITH(read_gmsh(d.write("bad3.msh", bad)), Catch::Contains("binary .msh files are not supported"));
  bad = kMsh22;
  bad.erase(bad.find("$EndElements"));
  CHECK_THROWS_WITH(read_gmsh(d.write("bad4.msh", bad)), Catch::Contains("expected $EndElements"));
  bad = kMsh22;
  bad.replace(bad.find("4 0 0 1"), 7, "4 0.5 0.5 0");  // flattens the first tet
  CHECK_THROWS_WITH(read_gmsh(d.write("bad5.msh", bad)), Catch::Contains("degenerate"));
  CHECK_THROWS_WITH(read_mesh(d.write("x.obj", "")), Catch::Contains("unknown mesh format"));
  d.write("t.node", "2 3 0 0\n1 0 0 0\n");
  d.write("t.ele", "1 4 0\n");
  CHECK_THROWS_WITH(read_tetgen((d.path / "t").string()), Catch::Contains("t.node:1: point count 2 is more than the 1 the rest of the file could hold"));
  d.write("t.node", "2 3 0 0\n1 0 0 0\n# padding that a reader must not take for a point\n");
  CHECK_THROWS_WITH(read_tetgen((d.path / "t").string()), Catch::Contains("t.node:4: file ends where a point line was expected"));
}

TEST_CASE("surfaces: OFF and STL give the enclosed volume", "[fem][mesh_io]") {
  TempDir d;
  const std::string off = d.write("tet.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n");
  CHECK(read_surface(off).volume() == Approx(1.0 / 6.0));
  const std::string stl = d.write("tet.stl",
      "solid t\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\n"
      "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0 1\nendloop\nendfacet\n"
      "facet normal 0 0 0\nouter loop\nvertex 1 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\n"
      "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n");
  const Surface s = read_surface(stl);
  CHECK(s.vertices.size() == 4);
  CHECK(s.volume() == Approx(1.0 / 6.0));
}
