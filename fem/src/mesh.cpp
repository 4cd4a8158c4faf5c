#include "pmg/fem/mesh.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

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

  std::map<std::array<index_t, 4>, index_t> seen;
  std::map<std::array<index_t, 3>, int> face_count;
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
      if (++face_count[f] > 2)
        throw MeshError("face (" + std::to_string(f[0]) + ", " + std::to_string(f[1]) + ", " +
                        std::to_string(f[2]) + ") of " + elem(e) +
                        " is shared by more than two elements (non-manifold)");
    }
  }
}

}  // namespace pmg::fem
