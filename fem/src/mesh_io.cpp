#include "pmg/fem/mesh_io.hpp"

#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/text_reader.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace pmg::fem {

namespace {

std::ifstream open(const std::string& path, std::ios::openmode mode = std::ios::in) {
  std::ifstream in(path, mode);
  if (!in) throw InputError(path + ": cannot open for reading");
  return in;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// Collects nodes by file tag and tetrahedra by tags, then keeps the vertices tets use, in file
/// order.
struct MeshBuilder {
  std::vector<Vec3> nodes;
  std::unordered_map<long long, index_t> node_index;
  std::vector<std::array<long long, 4>> tets;
  std::vector<long> tet_lines;  // for errors naming the line of a bad element

  void add_node(const TextReader& rd, long long tag, const Vec3& x) {
    if (!node_index.emplace(tag, static_cast<index_t>(nodes.size())).second)
      rd.fail("node " + std::to_string(tag) + " is defined twice");
    nodes.push_back(x);
  }
  TetMesh build(const std::string& name, std::vector<std::string>* warnings, MeshCheckOptions opt) {
    if (tets.empty()) throw MeshError(name + ": no tetrahedra in the file");
    TetMesh m;
    std::vector<index_t> compact(nodes.size(), -1);
    m.tets.resize(tets.size());
    for (size_t e = 0; e < tets.size(); ++e)
      for (int i = 0; i < 4; ++i) {
        const auto it = node_index.find(tets[e][i]);
        if (it == node_index.end())
          throw MeshError(name + ":" + std::to_string(tet_lines[e]) + ": element refers to node " +
                          std::to_string(tets[e][i]) + ", which is not defined");
        m.tets[e][i] = it->second;
        compact[it->second] = 0;
      }
    for (size_t v = 0; v < nodes.size(); ++v)
      if (compact[v] == 0) {
        compact[v] = m.num_vertices();
        m.vertices.push_back(nodes[v]);
      }
    for (Tet& t : m.tets)
      for (index_t& v : t) v = compact[v];
    const size_t dropped = nodes.size() - m.vertices.size();
    if (dropped && warnings)
      warnings->push_back(name + ": " + std::to_string(dropped) +
                          " nodes belong to no tetrahedron and were dropped");
    opt.fix_orientation = true;  // files follow either orientation convention
    try {
      check_mesh(m, opt);
    } catch (const MeshError& e) {
      throw MeshError(name + ": " + e.what());
    }
    return m;
  }
};

// Gmsh element types that are tetrahedra, with their node counts.
int gmsh_tet_nodes(long long type) {
  switch (type) {
    case 4: return 4;    // linear
    case 11: return 10;  // quadratic
    case 29: return 20;  // cubic
    case 30: return 35;  // quartic
    default: return 0;
  }
}

void gmsh_skip_section(TextReader& rd, const std::string& name) {
  std::string line;
  const std::string end = "$End" + name.substr(1);
  while (rd.next_line(line))
    if (line.rfind(end, 0) == 0) return;
  rd.fail("section " + name + " is not closed by " + end);
}

void gmsh_expect_end(TextReader& rd, const char* end) {
  std::string line;
  if (!rd.next_data_line(line) || line.rfind(end, 0) != 0) rd.fail(std::string("expected ") + end);
}

}  // namespace

TetMesh read_gmsh(std::istream& in, const std::string& path, std::vector<std::string>* warnings,
                  const MeshCheckOptions& options) {
  TextReader rd(in, path, '\0');
  MeshBuilder b;
  double version = 0.0;
  bool higher_order = false;
  std::string line;
  // The fewest bytes a node or element line takes ("1 0 0 0\n", "1 4 0 1 2 3 4\n"): every count
  // is checked against what the rest of the file could hold before anything is read or reserved.
  auto most = [&](long long bytes_per_item) { return (rd.remaining_bytes() + 1) / bytes_per_item; };
  while (rd.next_data_line(line)) {
    const std::string section = split_tokens(line).front();  // a data line has a token
    if (section == "$MeshFormat") {
      const auto t = rd.next_tokens("the format line");
      if (t.size() < 3) rd.fail("format line must read 'version file-type data-size'");
      version = rd.to_real(t[0], "a version number");
      if (t[1] != "0") rd.fail("binary .msh files are not supported; save the mesh as ASCII");
      if (version != 2.2 && version != 4.1 && version != 4.0 && version != 2.0 && version != 2.1)
        rd.fail("unsupported .msh version " + t[0] + " (2.2 or 4.1)");
      gmsh_expect_end(rd, "$EndMeshFormat");
    } else if (section == "$Nodes") {
      if (version == 0.0) rd.fail("$Nodes before $MeshFormat");
      if (version < 4) {
        const long long n = rd.to_count(rd.next_tokens("the node count")[0], "node count", most(8));
        for (long long k = 0; k < n; ++k) {
          const auto t = rd.next_tokens("a node line");
          if (t.size() < 4) rd.fail("node line must read 'tag x y z'");
          b.add_node(rd, rd.to_integer(t[0], "node tag"),
                     Vec3(rd.to_real(t[1]), rd.to_real(t[2]), rd.to_real(t[3])));
        }
      } else {
        const auto h = rd.next_tokens("the nodes header");
        if (h.size() < 2) rd.fail("nodes header must read 'numEntityBlocks numNodes minTag maxTag'");
        const long long blocks = rd.to_count(h[0], "block count", most(8));
        for (long long blk = 0; blk < blocks; ++blk) {
          const auto bh = rd.next_tokens("a node block header");
          if (bh.size() != 4) rd.fail("node block header must read 'dim tag parametric numNodes'");
          if (bh[2] != "0") rd.fail("parametric node coordinates are not supported");
          // A tag line and a coordinate line per node: at least 2 + 6 bytes.
          const long long n = rd.to_count(bh[3], "node count", most(8));
          std::vector<long long> tags;
          for (long long k = 0; k < n; ++k) {
            const auto t = rd.next_tokens("a node tag");
            if (t.size() != 1) rd.fail("a node tag line holds one tag");
            tags.push_back(rd.to_integer(t[0], "node tag"));
          }
          for (long long tag : tags) {
            const auto t = rd.next_tokens("node coordinates");
            if (t.size() != 3) rd.fail("node coordinates must read 'x y z'");
            b.add_node(rd, tag, Vec3(rd.to_real(t[0]), rd.to_real(t[1]), rd.to_real(t[2])));
          }
        }
      }
      gmsh_expect_end(rd, "$EndNodes");
    } else if (section == "$Elements") {
      if (version == 0.0) rd.fail("$Elements before $MeshFormat");
      auto add_tet = [&](const std::vector<std::string>& t, size_t first, int nodes) {
        if (t.size() != first + nodes)
          rd.fail("tetrahedron with " + std::to_string(nodes) + " nodes expects " +
                  std::to_string(first + nodes) + " fields, found " + std::to_string(t.size()));
        std::array<long long, 4> tet;
        for (int i = 0; i < 4; ++i) tet[i] = rd.to_integer(t[first + i], "node tag");
        higher_order |= nodes > 4;
        b.tets.push_back(tet);
        b.tet_lines.push_back(rd.line_number());
      };
      if (version < 4) {
        const long long n = rd.to_count(rd.next_tokens("the element count")[0], "element count", most(6));
        for (long long k = 0; k < n; ++k) {
          const auto t = rd.next_tokens("an element line");
          if (t.size() < 3) rd.fail("element line must read 'tag type ntags tags... nodes...'");
          const int nodes = gmsh_tet_nodes(rd.to_integer(t[1], "element type"));
          const long long tags = rd.to_count(t[2], "tag count", static_cast<long long>(t.size()) - 3,
                                             "fields that follow it on the line");
          if (nodes) add_tet(t, 3 + static_cast<size_t>(tags), nodes);
        }
      } else {
        const auto h = rd.next_tokens("the elements header");
        const long long blocks = rd.to_count(h[0], "block count", most(8));
        for (long long blk = 0; blk < blocks; ++blk) {
          const auto bh = rd.next_tokens("an element block header");
          if (bh.size() != 4) rd.fail("element block header must read 'dim tag type numElements'");
          const int nodes = gmsh_tet_nodes(rd.to_integer(bh[2], "element type"));
          const long long n = rd.to_count(bh[3], "element count", most(2));
          for (long long k = 0; k < n; ++k) {
            const auto t = rd.next_tokens("an element line");
            if (nodes) add_tet(t, 1, nodes);
          }
        }
      }
      gmsh_expect_end(rd, "$EndElements");
    } else if (section[0] == '$') {
      gmsh_skip_section(rd, section);
    } else {
      rd.fail("expected a $Section, found '" + printable(line) + "'");
    }
  }
  if (version == 0.0) throw MeshError(path + ": no $MeshFormat section: not a Gmsh .msh file");
  if (higher_order && warnings)
    warnings->push_back(path + ": higher-order tetrahedra: only their corner nodes are used");
  return b.build(path, warnings, options);
}

TetMesh read_gmsh(const std::string& path, std::vector<std::string>* warnings,
                  const MeshCheckOptions& options) {
  auto in = open(path);
  return read_gmsh(in, path, warnings, options);
}

TetMesh read_tetgen(std::istream& node_in, const std::string& node_name, std::istream& ele_in,
                    const std::string& ele_name, std::vector<std::string>* warnings,
                    const MeshCheckOptions& options) {
  MeshBuilder b;
  {
    TextReader rd(node_in, node_name, '#');
    const auto h = rd.next_tokens("the header");
    if (h.size() < 2) rd.fail("header must read '<#points> <dimension> [<#attributes> <markers>]'");
    const long long n = rd.to_count(h[0], "point count", (rd.remaining_bytes() + 1) / 8);
    if (rd.to_integer(h[1], "dimension") != 3) rd.fail("dimension must be 3");
    for (long long k = 0; k < n; ++k) {
      const auto t = rd.next_tokens("a point line");
      if (t.size() < 4) rd.fail("point line must read 'index x y z ...'");
      b.add_node(rd, rd.to_integer(t[0], "point index"),
                 Vec3(rd.to_real(t[1]), rd.to_real(t[2]), rd.to_real(t[3])));
    }
  }
  {
    TextReader rd(ele_in, ele_name, '#');
    const auto h = rd.next_tokens("the header");
    if (h.size() < 2) rd.fail("header must read '<#tetrahedra> <nodes per tetrahedron> [<#attributes>]'");
    const long long n = rd.to_count(h[0], "tetrahedron count", (rd.remaining_bytes() + 1) / 10);
    const long long per = rd.to_integer(h[1], "nodes per tetrahedron");
    if (per != 4 && per != 10) rd.fail("nodes per tetrahedron must be 4 or 10");
    for (long long k = 0; k < n; ++k) {
      const auto t = rd.next_tokens("a tetrahedron line");
      if (static_cast<long long>(t.size()) < 1 + per) rd.fail("tetrahedron line has too few fields");
      std::array<long long, 4> tet;
      for (int i = 0; i < 4; ++i) tet[i] = rd.to_integer(t[1 + i], "point index");
      b.tets.push_back(tet);
      b.tet_lines.push_back(rd.line_number());
    }
  }
  return b.build(ele_name, warnings, options);
}

TetMesh read_tetgen(const std::string& base_in, std::vector<std::string>* warnings,
                    const MeshCheckOptions& options) {
  std::string base = base_in;
  for (const char* ext : {".node", ".ele"})
    if (ends_with(base, ext)) base.erase(base.size() - std::strlen(ext));
  auto node = open(base + ".node");
  auto ele = open(base + ".ele");
  return read_tetgen(node, base + ".node", ele, base + ".ele", warnings, options);
}

TetMesh read_mesh(const std::string& path, std::vector<std::string>* warnings,
                  const MeshCheckOptions& options) {
  if (ends_with(path, ".msh")) return read_gmsh(path, warnings, options);
  if (ends_with(path, ".node") || ends_with(path, ".ele")) return read_tetgen(path, warnings, options);
  if (ends_with(path, ".h5"))
    throw InputError(path + ": a mesh in PETSc's HDF5 format is read on the distributed route only (pmg compare "
                     "--distributed-mesh under mpirun); here: .msh, .node or .ele");
  throw InputError(path + ": unknown mesh format (expected .msh, .node or .ele)");
}

void write_tetgen(const std::string& base, const TetMesh& mesh) {
  std::ostringstream node, ele;
  node.precision(17);
  node << mesh.num_vertices() << " 3 0 0\n";
  for (index_t v = 0; v < mesh.num_vertices(); ++v)
    node << v + 1 << " " << mesh.vertices[v].x() << " " << mesh.vertices[v].y() << " "
         << mesh.vertices[v].z() << "\n";
  ele << mesh.num_tets() << " 4 0\n";
  for (index_t e = 0; e < mesh.num_tets(); ++e)
    ele << e + 1 << " " << mesh.tets[e][0] + 1 << " " << mesh.tets[e][1] + 1 << " "
        << mesh.tets[e][2] + 1 << " " << mesh.tets[e][3] + 1 << "\n";
  write_file_atomically(base + ".node", node.str());
  write_file_atomically(base + ".ele", ele.str());
}

double Surface::volume() const {
  double v = 0.0;
  for (const auto& t : triangles)
    v += vertices[t[0]].dot(vertices[t[1]].cross(vertices[t[2]])) / 6.0;
  return v;
}

namespace {

Surface read_off_text(std::istream& in, const std::string& path) {
  TextReader rd(in, path, '#');
  auto t = rd.next_tokens("the OFF header");
  if (t[0] != "OFF") rd.fail("an .off file starts with 'OFF'");
  if (t.size() == 1) t = rd.next_tokens("the counts line");
  else t.erase(t.begin());
  if (t.size() < 2) rd.fail("counts line must read '<#vertices> <#faces> <#edges>'");
  // "0 0 0\n" and "3 0 0 0\n": the fewest bytes of a vertex and a face line.
  const long long nv = rd.to_count(t[0], "vertex count", (rd.remaining_bytes() + 1) / 6);
  const long long nf = rd.to_count(t[1], "face count", (rd.remaining_bytes() + 1) / 8);
  Surface s;
  for (long long k = 0; k < nv; ++k) {
    const auto v = rd.next_tokens("a vertex line");
    if (v.size() < 3) rd.fail("vertex line must read 'x y z'");
    s.vertices.emplace_back(rd.to_real(v[0]), rd.to_real(v[1]), rd.to_real(v[2]));
  }
  for (long long k = 0; k < nf; ++k) {
    const auto f = rd.next_tokens("a face line");
    const long long n = rd.to_count(f[0], "face size", static_cast<long long>(f.size()) - 1,
                                     "vertex indices on the line");
    if (n < 3) rd.fail("face line must read 'n i1 ... in' with n >= 3");
    std::vector<index_t> ids;
    for (long long i = 0; i < n; ++i) {
      const long long id = rd.to_integer(f[1 + i], "vertex index");
      if (id < 0 || id >= nv) rd.fail("vertex index " + f[1 + i] + " out of range");
      ids.push_back(static_cast<index_t>(id));
    }
    for (long long i = 1; i + 1 < n; ++i) s.triangles.push_back({ids[0], ids[i], ids[i + 1]});
  }
  return s;
}

Surface read_stl_data(std::istream& in, const std::string& path) {
  std::string head(80, '\0');
  in.read(head.data(), 80);
  std::uint32_t count = 0;
  in.read(reinterpret_cast<char*>(&count), 4);
  in.clear();
  in.seekg(0, std::ios::end);
  const auto end = in.tellg();
  if (end < 0) throw InputError(path + ": cannot determine the file size");
  const auto size = static_cast<std::uint64_t>(end);
  Surface s;
  std::unordered_map<std::string, index_t> ids;  // merge coincident vertices
  auto vertex = [&](const Vec3& v) {
    std::string key(reinterpret_cast<const char*>(v.data()), sizeof(double) * 3);
    auto [it, inserted] = ids.emplace(key, static_cast<index_t>(s.vertices.size()));
    if (inserted) s.vertices.push_back(v);
    return it->second;
  };
  if (size == 84 + 50ull * count && count > 0) {  // binary: the size backs the count
    in.seekg(84);
    for (std::uint32_t k = 0; k < count; ++k) {
      float data[12];
      char attr[2];
      in.read(reinterpret_cast<char*>(data), sizeof data);
      in.read(attr, 2);
      std::array<index_t, 3> t;
      for (int i = 0; i < 3; ++i) {
        const Vec3 x(data[3 + 3 * i], data[4 + 3 * i], data[5 + 3 * i]);
        if (!x.allFinite())
          throw InputError(path + ": triangle " + std::to_string(k) + " has a non-finite coordinate");
        t[i] = vertex(x);
      }
      s.triangles.push_back(t);
    }
    return s;
  }
  in.clear();
  in.seekg(0);
  TextReader rd(in, path, '\0');
  std::string line;
  std::vector<index_t> facet;
  while (rd.next_data_line(line)) {
    const auto t = split_tokens(line);  // a data line has a token
    if (t[0] == "vertex") {
      if (t.size() != 4) rd.fail("vertex line must read 'vertex x y z'");
      if (facet.size() == 3) rd.fail("a facet must have 3 vertices, this one has more");
      facet.push_back(vertex(Vec3(rd.to_real(t[1]), rd.to_real(t[2]), rd.to_real(t[3]))));
    } else if (t[0] == "endfacet") {
      if (facet.size() != 3) rd.fail("a facet must have 3 vertices");
      s.triangles.push_back({facet[0], facet[1], facet[2]});
      facet.clear();
    }
  }
  if (s.triangles.empty()) throw InputError(path + ": no triangles (not an STL file?)");
  return s;
}

}  // namespace

Surface read_off(std::istream& in, const std::string& name) { return read_off_text(in, name); }
Surface read_stl(std::istream& in, const std::string& name) { return read_stl_data(in, name); }

Surface read_surface(const std::string& path) {
  if (ends_with(path, ".off")) {
    auto in = open(path);
    return read_off_text(in, path);
  }
  if (ends_with(path, ".stl")) {
    auto in = open(path, std::ios::binary);
    return read_stl_data(in, path);
  }
  throw InputError(path + ": unknown surface format (expected .off or .stl)");
}

}  // namespace pmg::fem
