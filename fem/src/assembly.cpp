#include "pmg/fem/assembly.hpp"
#include "row_groups.hpp"

#include <algorithm>

namespace pmg::fem {

BlockAssembler::BlockAssembler(const BBSpace& space, std::vector<index_t> free_index)
    : space_(&space), n_(space.nodes_per_element()), free_index_(std::move(free_index)) {
  if (free_index_.size() != static_cast<size_t>(space.num_nodes()))
    throw InputError("assembler: free_index must have one entry per node");
  for (index_t f : free_index_) num_free_ = std::max(num_free_, f + 1);
  const index_t ne = space.mesh().num_tets();

  // Greedy colouring: the smallest colour not used by an element sharing a node. Each node's
  // elements, in ascending order, as one array with offsets (a counting sort).
  std::vector<offset_t> start;
  std::vector<index_t> node_elements;
  detail::group_by_row(space.num_nodes(), ne, n_, [&](index_t e, int a) {
    return std::pair<index_t, index_t>(space.element_nodes(e)[a], e);
  }, start, node_elements);
  std::vector<int> color(ne, -1);
  std::vector<index_t> used_by(64, -1);  // used_by[c] == e: colour c is taken for element e
  for (index_t e = 0; e < ne; ++e) {
    for (int a = 0; a < n_; ++a) {
      const index_t node = space.element_nodes(e)[a];
      for (offset_t q = start[node]; q < start[node + 1]; ++q) {
        const index_t other = node_elements[q];
        if (color[other] >= 0) {
          if (static_cast<size_t>(color[other]) >= used_by.size()) used_by.resize(2 * used_by.size(), -1);
          used_by[color[other]] = e;
        }
      }
    }
    int c = 0;
    while (c < static_cast<int>(used_by.size()) && used_by[c] == e) ++c;
    color[e] = c;
    if (static_cast<size_t>(c) >= colors_.size()) colors_.resize(c + 1);
    colors_[c].push_back(e);
  }
}


void BlockAssembler::build_pattern() const {
  std::call_once(pattern_once_, [&] {
    const BBSpace& space = *space_;
    const index_t ne = space.mesh().num_tets();

    // Calls fn(e, a, b, I, J) for every pair of free nodes (I, J) of every element e.
    auto for_each_free_pair = [&](auto&& fn) {
      for (index_t e = 0; e < ne; ++e) {
        const index_t* nodes = space.element_nodes(e);
        for (int a = 0; a < n_; ++a) {
          const index_t I = free_index_[nodes[a]];
          if (I < 0) continue;
          for (int b = 0; b < n_; ++b) {
            const index_t J = free_index_[nodes[b]];
            if (J >= 0) fn(e, a, b, I, J);
          }
        }
      }
    };

    // Pattern: block (I, J) for every pair of free nodes sharing an element.
    std::vector<std::vector<index_t>> rows(num_free_);
    for_each_free_pair([&](index_t, int, int, index_t I, index_t J) { rows[I].push_back(J); });
    auto p = std::make_shared<BlockPattern>();
    p->rows = p->cols = num_free_;
    p->row_ptr.assign(num_free_ + 1, 0);
    for (index_t I = 0; I < num_free_; ++I) {
      auto& r = rows[I];
      std::sort(r.begin(), r.end());
      r.erase(std::unique(r.begin(), r.end()), r.end());
      p->col_idx.insert(p->col_idx.end(), r.begin(), r.end());
      p->row_ptr[I + 1] = static_cast<offset_t>(p->col_idx.size());
      std::vector<index_t>().swap(r);
    }
    pattern_ = p;

    slots_.assign(static_cast<size_t>(ne) * n_ * n_, -1);
    for_each_free_pair([&](index_t e, int a, int b, index_t I, index_t J) {
      slots_[(static_cast<size_t>(e) * n_ + a) * n_ + b] = p->find(I, J);
    });
  });
}

}  // namespace pmg::fem
