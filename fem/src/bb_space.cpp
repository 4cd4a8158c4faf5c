#include "pmg/fem/bb_space.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

namespace pmg::fem {

namespace {

std::vector<MultiIndex> build_indices(int p) {
  return ordered_multi_indices(p, {{{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}},
                               {{{0, 1, 2}, {0, 1, 3}, {0, 2, 3}, {1, 2, 3}}});
}

double factorial(int n) {
  double f = 1.0;
  for (int i = 2; i <= n; ++i) f *= i;
  return f;
}

void check_degree(int p) {
  if (p < 1 || p > 3) throw InputError("degree " + std::to_string(p) + " not supported (1, 2 or 3)");
}

}  // namespace

std::vector<MultiIndex> ordered_multi_indices(int p, const std::array<std::array<int, 2>, 6>& edges,
                                              const std::array<std::array<int, 3>, 4>& faces) {
  std::vector<MultiIndex> out;
  for (int i = 0; i < 4; ++i) {
    MultiIndex a{0, 0, 0, 0};
    a[i] = p;
    out.push_back(a);
  }
  for (const auto& e : edges)
    for (int m = 1; m < p; ++m) {
      MultiIndex a{0, 0, 0, 0};
      a[e[0]] = p - m;
      a[e[1]] = m;
      out.push_back(a);
    }
  if (p == 3)
    for (const auto& f : faces) {
      MultiIndex a{0, 0, 0, 0};
      a[f[0]] = a[f[1]] = a[f[2]] = 1;
      out.push_back(a);
    }
  return out;
}

const std::vector<MultiIndex>& multi_indices(int p) {
  check_degree(p);
  static const std::vector<MultiIndex> tables[3] = {build_indices(1), build_indices(2),
                                                    build_indices(3)};
  return tables[p - 1];
}

int num_element_nodes(int p) { return (p + 1) * (p + 2) * (p + 3) / 6; }

int local_index(const MultiIndex& alpha) {
  const auto& list = multi_indices(alpha[0] + alpha[1] + alpha[2] + alpha[3]);
  return static_cast<int>(std::find(list.begin(), list.end(), alpha) - list.begin());
}

double bernstein(const MultiIndex& a, const Eigen::Vector4d& l) {
  const int p = a[0] + a[1] + a[2] + a[3];
  double v = factorial(p);
  for (int i = 0; i < 4; ++i) v *= std::pow(l[i], a[i]) / factorial(a[i]);
  return v;
}

Eigen::Vector4d bernstein_gradient(const MultiIndex& a, const Eigen::Vector4d& l) {
  // d/dλk B^p_a = p B^{p-1}_{a - e_k}
  const int p = a[0] + a[1] + a[2] + a[3];
  Eigen::Vector4d g = Eigen::Vector4d::Zero();
  for (int k = 0; k < 4; ++k) {
    if (a[k] == 0) continue;
    MultiIndex b = a;
    --b[k];
    g[k] = p * bernstein(b, l);
  }
  return g;
}

BBSpace::BBSpace(const TetMesh& mesh, int degree)
    : mesh_(&mesh), p_(degree), n_(num_element_nodes(degree)) {
  check_degree(degree);
  const auto& alpha = multi_indices(p_);
  positions_.assign(mesh.vertices.begin(), mesh.vertices.end());  // vertex nodes: node v = vertex v
  element_nodes_.resize(static_cast<size_t>(mesh.num_tets()) * n_);

  // Key of a non-vertex node: its (global vertex, multiplicity) pairs sorted by vertex id.
  using Key = std::array<std::pair<index_t, int>, 3>;
  std::map<Key, index_t> edge_nodes, face_nodes;
  std::map<std::pair<index_t, index_t>, int> edges;
  std::map<std::array<index_t, 3>, int> faces;
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    const Tet& t = mesh.tets[e];
    for (int a = 0; a < n_; ++a) {
      const MultiIndex& al = alpha[a];
      Key key{};
      int support = 0;
      for (int i = 0; i < 4; ++i)
        if (al[i] > 0) key[support++] = {t[i], al[i]};
      index_t id;
      if (support == 1) {
        id = key[0].first;
      } else {
        std::sort(key.begin(), key.begin() + support);
        auto& table = support == 2 ? edge_nodes : face_nodes;
        auto [it, inserted] = table.emplace(key, -1);
        if (inserted) {
          it->second = static_cast<index_t>(positions_.size());
          Vec3 X = Vec3::Zero();
          for (int i = 0; i < 4; ++i) X += (static_cast<double>(al[i]) / p_) * mesh.vertices[t[i]];
          positions_.push_back(X);
        }
        id = it->second;
      }
      element_nodes_[static_cast<size_t>(e) * n_ + a] = id;
    }
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) edges.emplace(std::minmax(t[i], t[j]), 0);
    for (int skip = 0; skip < 4; ++skip) {
      std::array<index_t, 3> f;
      for (int i = 0, k = 0; i < 4; ++i)
        if (i != skip) f[k++] = t[i];
      std::sort(f.begin(), f.end());
      faces.emplace(f, 0);
    }
  }
  num_edges_ = static_cast<index_t>(edges.size());
  num_faces_ = static_cast<index_t>(faces.size());
}

}  // namespace pmg::fem
