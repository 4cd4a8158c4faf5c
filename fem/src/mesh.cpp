#include "pmg/fem/mesh.hpp"

#include "row_groups.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <vector>
#include <utility>
#include <limits>
#include <cstdint>
#include <cmath>
#include <map>
#include <string>
#include <tuple>

namespace pmg::fem {

double TetMesh::signed_volume(index_t e) const {
  const Tet& t = tets[e];
  Mat3 D;
  D.col(0) = vertices[t[1]] - vertices[t[0]];
  D.col(1) = vertices[t[2]] - vertices[t[0]];
  D.col(2) = vertices[t[3]] - vertices[t[0]];
  return D.determinant() / 6.0;
}

double TetMesh::diameter() const {
  if (vertices.empty()) return 0.0;
  Vec3 lo = vertices[0], hi = vertices[0];
  for (const Vec3& v : vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return (hi - lo).norm();
}

namespace {
std::string elem(index_t e) { return "element " + std::to_string(e); }
}  // namespace

void check_mesh(TetMesh& mesh, const MeshCheckOptions& options) {
  const index_t nv = mesh.num_vertices();
  if (mesh.tets.empty()) throw MeshError("mesh has no elements");
  for (index_t v = 0; v < nv; ++v)
    if (!mesh.vertices[v].allFinite())
      throw MeshError("vertex " + std::to_string(v) + " has a non-finite coordinate");
  std::vector<char> used(nv, 0);
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    const Tet& t = mesh.tets[e];
    for (int i = 0; i < 4; ++i) {
      if (t[i] < 0 || t[i] >= nv)
        throw MeshError(elem(e) + " refers to vertex " + std::to_string(t[i]) + ", outside 0.." +
                        std::to_string(nv - 1));
      for (int j = 0; j < i; ++j)
        if (t[i] == t[j])
          throw MeshError(elem(e) + " uses vertex " + std::to_string(t[i]) + " twice");
      used[t[i]] = 1;
    }
  }
  for (index_t v = 0; v < nv; ++v)
    if (!used[v]) throw MeshError("vertex " + std::to_string(v) + " belongs to no element");

  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    Tet& t = mesh.tets[e];
    double edge = 0.0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) edge += (mesh.vertices[t[i]] - mesh.vertices[t[j]]).norm();
    edge /= 6.0;
    const double v = mesh.signed_volume(e);
    if (!(std::abs(v) > options.degenerate_volume * edge * edge * edge / 6.0))
      throw MeshError(elem(e) + " is degenerate (volume " + std::to_string(v) + ")");
    if (v < 0.0) {
      if (!options.fix_orientation)
        throw MeshError(elem(e) + " is inverted (negative volume " + std::to_string(v) +
                        "); reorder its vertices or enable fix_orientation");
      std::swap(t[2], t[3]);
    }
  }

  // Faces: each interior face joins two elements, which must lie on opposite sides of it.
  struct FaceUse {
    index_t element, opposite;
    int count;
  };
  std::map<std::array<index_t, 4>, index_t> seen;
  std::map<std::array<index_t, 3>, FaceUse> faces;
  auto side = [&](const std::array<index_t, 3>& f, index_t p) {
    const Vec3& a = mesh.vertices[f[0]];
    return (mesh.vertices[f[1]] - a).cross(mesh.vertices[f[2]] - a).dot(mesh.vertices[p] - a);
  };
  auto face_name = [](const std::array<index_t, 3>& f) {
    return "face (" + std::to_string(f[0]) + ", " + std::to_string(f[1]) + ", " + std::to_string(f[2]) + ")";
  };
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    Tet s = mesh.tets[e];
    std::sort(s.begin(), s.end());
    const auto [it, inserted] = seen.emplace(s, e);
    if (!inserted)
      throw MeshError(elem(e) + " duplicates element " + std::to_string(it->second));
    for (int skip = 0; skip < 4; ++skip) {
      std::array<index_t, 3> f;
      for (int i = 0, k = 0; i < 4; ++i)
        if (i != skip) f[k++] = s[i];
      const auto use = faces.try_emplace(f, FaceUse{e, s[skip], 0}).first;
      if (++use->second.count > 2)
        throw MeshError(face_name(f) + " of " + elem(e) +
                        " is shared by more than two elements (non-manifold)");
      if (use->second.count == 2 && !options.allow_tangled &&
          side(f, use->second.opposite) * side(f, s[skip]) > 0)
        throw MeshError(elem(e) + " and " + elem(use->second.element) + " lie on the same side of their shared " +
                        face_name(f) + ": the mesh is tangled (a vertex pushed through a face, or overlapping "
                        "elements); untangle it, or allow it on purpose (allow_tangled; pmg: --allow tangled)");
    }
  }
  if (options.allow_cracked) return;
  // Cracks: distinct vertices at the same point (an unwelded seam) ...
  std::vector<index_t> order(nv);
  for (index_t v = 0; v < nv; ++v) order[v] = v;
  auto less = [&](index_t a, index_t b) {
    const Vec3 &x = mesh.vertices[a], &y = mesh.vertices[b];
    return std::tie(x[0], x[1], x[2]) < std::tie(y[0], y[1], y[2]);
  };
  std::sort(order.begin(), order.end(), less);
  for (index_t k = 1; k < nv; ++k)
    if (mesh.vertices[order[k]] == mesh.vertices[order[k - 1]]) {
      const Vec3& x = mesh.vertices[order[k]];
      throw MeshError("vertices " + std::to_string(std::min(order[k], order[k - 1])) + " and " +
                      std::to_string(std::max(order[k], order[k - 1])) + " lie at the same point (" +
                      std::to_string(x[0]) + ", " + std::to_string(x[1]) + ", " + std::to_string(x[2]) +
                      "): the mesh is cracked (an unwelded seam); weld them, or allow it on purpose "
                      "(allow_cracked; pmg: --allow cracked)");
    }
  // ... and a boundary that is not a closed 2-manifold: every boundary edge in two boundary faces.
  std::map<std::pair<index_t, index_t>, int> boundary_edges;
  for (const auto& [f, use] : faces)
    if (use.count == 1)
      for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) ++boundary_edges[{f[i], f[j]}];
  for (const auto& [edge, count] : boundary_edges)
    if (count != 2)
      throw MeshError("boundary edge (" + std::to_string(edge.first) + ", " + std::to_string(edge.second) +
                      ") belongs to " + std::to_string(count) +
                      " boundary faces, not 2: the boundary is not a manifold (elements touching along an "
                      "edge only?); allow it on purpose with allow_cracked (pmg: --allow cracked)");
}

void allow_mesh_defect(MeshCheckOptions& options, const std::string& name) {
  if (name == "tangled") options.allow_tangled = true;
  else if (name == "cracked") options.allow_cracked = true;
  else throw InputError("'" + name + "' is not a mesh defect that can be allowed (tangled, cracked)");
}

std::vector<std::string> allowed_mesh_defects(const MeshCheckOptions& options) {
  std::vector<std::string> names;
  if (options.allow_tangled) names.emplace_back("tangled");
  if (options.allow_cracked) names.emplace_back("cracked");
  return names;
}

namespace {

/// The edges of `in` in the order the elements first meet them (element by element, local edges
/// 01, 02, 03, 12, 13, 23): per position 6e + k, the number of its edge in that order.
std::vector<index_t> number_edges(const TetMesh& in, Refinement& record) {
  static constexpr int kEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  const index_t T = in.num_tets();
  auto ends = [&](index_t pos) { return std::minmax(in.tets[pos / 6][kEdge[pos % 6][0]], in.tets[pos / 6][kEdge[pos % 6][1]]); };
  // Each edge's positions grouped under its lower vertex, in position order.
  std::vector<offset_t> start;
  std::vector<index_t> at;
  detail::group_by_row<index_t>(
      in.num_vertices(), 6 * T, 1, [&](index_t pos, int) { return std::pair<index_t, index_t>{ends(pos).first, pos}; },
      start, at);
  // first[pos]: the first position of pos's edge (within a row, equal upper vertices).
  std::vector<index_t> first(static_cast<size_t>(6) * T);
#pragma omp parallel for schedule(dynamic, 1024)
  for (index_t v = 0; v < in.num_vertices(); ++v) {
    std::vector<std::pair<index_t, index_t>> row;  // (upper vertex, position), positions ascending
    for (offset_t k = start[v]; k < start[v + 1]; ++k) row.emplace_back(ends(at[k]).second, at[k]);
    std::stable_sort(row.begin(), row.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    for (size_t k = 0; k < row.size(); ++k)
      first[row[k].second] = k > 0 && row[k].first == row[k - 1].first ? first[row[k - 1].second] : row[k].second;
  }
  std::vector<index_t> number(first.size());
  record.midpoints.clear();
  for (size_t pos = 0; pos < first.size(); ++pos) {
    if (first[pos] == static_cast<index_t>(pos)) {
      number[pos] = static_cast<index_t>(record.midpoints.size());
      const auto [a, b] = ends(static_cast<index_t>(pos));
      record.midpoints.push_back({a, b});
    } else {
      number[pos] = number[first[pos]];
    }
  }
  return number;
}

TetMesh refine_once(const TetMesh& in, Refinement& record) {
  TetMesh out;
  record.coarse_vertices = in.num_vertices();
  const std::vector<index_t> edge = number_edges(in, record);
  out.vertices.reserve(in.vertices.size() + record.midpoints.size());
  out.vertices = in.vertices;
  for (const auto& [a, b] : record.midpoints) out.vertices.push_back(0.5 * (in.vertices[a] + in.vertices[b]));
  const index_t nc = record.coarse_vertices;
  auto mid = [&](index_t e, int i, int j) {
    static constexpr int kLocal[4][4] = {{-1, 0, 1, 2}, {0, -1, 3, 4}, {1, 3, -1, 5}, {2, 4, 5, -1}};
    return nc + edge[6 * static_cast<size_t>(e) + kLocal[i][j]];
  };
  auto add = [&](Tet t) {
    const Vec3& X0 = out.vertices[t[0]];
    const double det = (out.vertices[t[1]] - X0).cross(out.vertices[t[2]] - X0).dot(out.vertices[t[3]] - X0);
    if (det < 0) std::swap(t[2], t[3]);
    out.tets.push_back(t);
  };
  out.tets.reserve(8 * in.tets.size());
  for (index_t e = 0; e < in.num_tets(); ++e) {
    const Tet& t = in.tets[e];
    // m[i][j]: midpoint of edge ij.
    index_t m[4][4];
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) m[i][j] = m[j][i] = mid(e, i, j);
    for (int i = 0; i < 4; ++i) {  // corner tets
      Tet c;
      for (int j = 0; j < 4; ++j) c[j] = j == i ? t[i] : m[i][j];
      add(c);
    }
    // Octahedron: the three diagonals join midpoints of opposite edges (01-23, 02-13, 03-12).
    const int pairs[3][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2}};
    int best = 0;
    double shortest = 1e300;
    for (int d = 0; d < 3; ++d) {
      const auto& q = pairs[d];
      const double len = (out.vertices[m[q[0]][q[1]]] - out.vertices[m[q[2]][q[3]]]).squaredNorm();
      if (len < shortest) shortest = len, best = d;
    }
    const auto& q = pairs[best];
    const index_t a = m[q[0]][q[1]], b = m[q[2]][q[3]];
    // The equator around diagonal ab, in cyclic order: consecutive midpoints share a tet vertex.
    const index_t ring[4] = {m[q[0]][q[2]], m[q[0]][q[3]], m[q[1]][q[3]], m[q[1]][q[2]]};
    for (int k = 0; k < 4; ++k) add({a, b, ring[k], ring[(k + 1) % 4]});
  }
  return out;
}

}  // namespace

TetMesh refine_uniform(const TetMesh& mesh, int levels, std::vector<Refinement>* record) {
  if (levels < 0) throw MeshError("refine_uniform: levels must be >= 0");
  if (record) record->clear();
  TetMesh m = mesh;
  for (int l = 0; l < levels; ++l) {
    Refinement r;
    m = refine_once(m, r);
    if (record) record->push_back(std::move(r));
  }
  return m;
}


namespace {
/// The 21 low bits of x spread to every third bit (bit i to bit 3i).
std::uint64_t spread_bits(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}
}  // namespace

std::vector<index_t> morton_order(const TetMesh& mesh) {
  const index_t ne = mesh.num_tets();
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (const Vec3& v : mesh.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  const Vec3 extent = (hi - lo).cwiseMax(Vec3::Constant(1e-300));
  std::vector<std::pair<std::uint64_t, index_t>> keyed(static_cast<size_t>(ne));
#pragma omp parallel for schedule(static)
  for (index_t e = 0; e < ne; ++e) {
    Vec3 c = Vec3::Zero();
    for (int i = 0; i < 4; ++i) c += 0.25 * mesh.vertices[mesh.tets[e][i]];
    std::uint64_t key = 0;
    for (int d = 0; d < 3; ++d) {
      const double s = std::clamp((c[d] - lo[d]) / extent[d], 0.0, 1.0);
      key |= spread_bits(static_cast<std::uint64_t>(s * 2097151.0)) << d;
    }
    keyed[static_cast<size_t>(e)] = {key, e};
  }
  std::sort(keyed.begin(), keyed.end());  // ties by element number: deterministic
  std::vector<index_t> order(static_cast<size_t>(ne));
  for (index_t pos = 0; pos < ne; ++pos) order[static_cast<size_t>(pos)] = keyed[static_cast<size_t>(pos)].second;
  return order;
}

TetMesh reorder_for_locality(const TetMesh& mesh) {
  const std::vector<index_t> order = morton_order(mesh);
  std::vector<index_t> renumber(mesh.vertices.size(), -1);
  TetMesh out;
  out.vertices.reserve(mesh.vertices.size());
  out.tets.resize(mesh.tets.size());
  for (size_t pos = 0; pos < order.size(); ++pos) {
    const Tet& t = mesh.tets[static_cast<size_t>(order[pos])];
    for (int i = 0; i < 4; ++i) {
      index_t& v = renumber[static_cast<size_t>(t[i])];
      if (v < 0) {
        v = static_cast<index_t>(out.vertices.size());
        out.vertices.push_back(mesh.vertices[static_cast<size_t>(t[i])]);
      }
      out.tets[pos][i] = v;
    }
  }
  for (size_t v = 0; v < renumber.size(); ++v)  // vertices no element uses keep a place at the end
    if (renumber[v] < 0) out.vertices.push_back(mesh.vertices[v]);
  return out;
}

}  // namespace pmg::fem
