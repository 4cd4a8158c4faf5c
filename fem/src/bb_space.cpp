#include "pmg/fem/bb_space.hpp"
#include "row_groups.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
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

namespace {

/// The distinct keys of each row: row r's candidates (in [start[r], start[r + 1]) of `keys`, as
/// detail::group_by_row leaves them) sorted and made unique, compacted in place; `start` becomes the unique rows' offsets. The id of a key
/// is its position in the compacted array (find_key).
template <typename K>
void unique_rows(std::vector<offset_t>& start, std::vector<K>& keys) {
  const index_t rows = static_cast<index_t>(start.size()) - 1;
  std::vector<offset_t> count(rows + 1, 0);
#pragma omp parallel for schedule(dynamic, 1024)
  for (index_t r = 0; r < rows; ++r) {
    K* first = keys.data() + start[r];
    K* last = keys.data() + start[r + 1];
    std::sort(first, last);
    count[r + 1] = std::unique(first, last) - first;
  }
  offset_t next = 0;
  for (index_t r = 0; r < rows; ++r) {  // compact: row r's unique keys move down to `next`
    const offset_t from = start[r], n = count[r + 1];
    std::copy(keys.begin() + from, keys.begin() + from + n, keys.begin() + next);
    start[r] = next;
    next += n;
  }
  start[rows] = next;
  keys.resize(next);
}

/// The position of `key` in row r of unique_rows()' result.
template <typename K>
offset_t find_key(const std::vector<offset_t>& start, const std::vector<K>& keys, index_t r, K key) {
  return std::lower_bound(keys.begin() + start[r], keys.begin() + start[r + 1], key) - keys.begin();
}

constexpr int kTetEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

}  // namespace

BBSpace::BBSpace(const TetMesh& mesh, int degree)
    : mesh_(&mesh), p_(degree), n_(num_element_nodes(degree)) {
  check_degree(degree);
  const auto& alpha = multi_indices(p_);
  const index_t nv = static_cast<index_t>(mesh.vertices.size()), ne = mesh.num_tets();
  positions_.assign(mesh.vertices.begin(), mesh.vertices.end());  // vertex nodes: node v = vertex v
  element_nodes_.resize(static_cast<size_t>(ne) * n_);

  // The mesh's edges and faces, numbered by their smallest vertex, then the others (arrays, no
  // maps: a 10M-unknown mesh has millions of each).
  std::vector<offset_t> edge_start, face_start;
  std::vector<index_t> edge_hi;            // per edge: its larger vertex (row: the smaller)
  std::vector<std::uint64_t> face_rest;    // per face: its two larger vertices (row: the smallest)
  detail::group_by_row(nv, ne, 6, [&](index_t e, int k) {
    const index_t a = mesh.tets[e][kTetEdges[k][0]], b = mesh.tets[e][kTetEdges[k][1]];
    return std::pair<index_t, index_t>(std::min(a, b), std::max(a, b));
  }, edge_start, edge_hi);
  unique_rows(edge_start, edge_hi);
  detail::group_by_row(nv, ne, 4, [&](index_t e, int skip) {  // the face without vertex `skip`
    std::array<index_t, 3> f;
    for (int i = 0, k = 0; i < 4; ++i)
      if (i != skip) f[k++] = mesh.tets[e][i];
    std::sort(f.begin(), f.end());
    return std::pair<index_t, std::uint64_t>(f[0], (static_cast<std::uint64_t>(f[1]) << 32) | static_cast<std::uint32_t>(f[2]));
  }, face_start, face_rest);
  unique_rows(face_start, face_rest);
  num_edges_ = static_cast<index_t>(edge_hi.size());
  num_faces_ = static_cast<index_t>(face_rest.size());

  // Non-vertex nodes numbered in the order the elements first meet them (element by element,
  // node by node): an edge carries p - 1 nodes, told apart by the smaller vertex's multiplicity;
  // a face (p = 3) one.
  std::vector<index_t> edge_node(static_cast<size_t>(num_edges_) * std::max(p_ - 1, 0), -1);
  std::vector<index_t> face_node(p_ == 3 ? num_faces_ : 0, -1);
  positions_.reserve(static_cast<size_t>(nv) + edge_node.size() + face_node.size());  // every node once
  for (index_t e = 0; e < ne; ++e) {
    const Tet& t = mesh.tets[e];
    for (int a = 0; a < n_; ++a) {
      const MultiIndex& al = alpha[a];
      std::array<std::pair<index_t, int>, 3> key{};
      int support = 0;
      for (int i = 0; i < 4; ++i)
        if (al[i] > 0) key[support++] = {t[i], al[i]};
      index_t* slot = nullptr;
      if (support == 1) {
        element_nodes_[static_cast<size_t>(e) * n_ + a] = key[0].first;
        continue;
      }
      std::sort(key.begin(), key.begin() + support);
      if (support == 2) {
        const offset_t edge = find_key(edge_start, edge_hi, key[0].first, key[1].first);
        slot = &edge_node[static_cast<size_t>(edge) * (p_ - 1) + (key[0].second - 1)];
      } else {
        const std::uint64_t rest = (static_cast<std::uint64_t>(key[1].first) << 32) | static_cast<std::uint32_t>(key[2].first);
        slot = &face_node[find_key(face_start, face_rest, key[0].first, rest)];
      }
      if (*slot < 0) {
        *slot = static_cast<index_t>(positions_.size());
        Vec3 X = Vec3::Zero();
        for (int i = 0; i < 4; ++i) X += (static_cast<double>(al[i]) / p_) * mesh.vertices[t[i]];
        positions_.push_back(X);
      }
      element_nodes_[static_cast<size_t>(e) * n_ + a] = *slot;
    }
  }
}

}  // namespace pmg::fem
