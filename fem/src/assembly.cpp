#include "pmg/fem/assembly.hpp"
#include "row_groups.hpp"

#include "pmg/sparse/pattern_rows.hpp"

#include <algorithm>

namespace pmg::fem {

namespace {
constexpr int kMaxNodes = 20;  ///< nodes of a cubic element, the highest degree a BBSpace takes
}  // namespace

BlockAssembler::BlockAssembler(const BBSpace& space, std::vector<index_t> free_index)
    : space_(&space), n_(space.nodes_per_element()), free_index_(std::move(free_index)), ranges_(space) {
  if (free_index_.size() != static_cast<size_t>(space.num_nodes()))
    throw InputError("assembler: free_index must have one entry per node");
  for (index_t f : free_index_) num_free_ = std::max(num_free_, f + 1);
}

void BlockAssembler::build_pattern() const {
  std::call_once(pattern_once_, [&] {
    const BBSpace& space = *space_;
    const index_t ne = space.mesh().num_tets();

    // Each free node's elements, as e n + a (fixed nodes under a row of their own, num_free_,
    // dropped after the pattern is built).
    std::vector<offset_t>& start = row_start_;
    std::vector<offset_t>& elements = row_entries_;
    detail::group_by_row(num_free_ + 1, ne, n_, [&](index_t e, int a) {
      const index_t I = free_index_[space.element_nodes(e)[a]];
      return std::pair<index_t, offset_t>(I < 0 ? num_free_ : I, static_cast<offset_t>(e) * n_ + a);
    }, start, elements);
    // Pattern: block (I, J) for every pair of free nodes sharing an element.
    const std::shared_ptr<BlockPattern> p = pattern_by_rows(num_free_, num_free_, [&](index_t I, auto&& add) {
      for (offset_t q = start[I]; q < start[I + 1]; ++q) {
        const index_t* nodes = space.element_nodes(static_cast<index_t>(elements[q] / n_));
        for (int b = 0; b < n_; ++b)
          if (const index_t J = free_index_[nodes[b]]; J >= 0) add(J);
      }
    });
    pattern_ = p;
    elements.resize(static_cast<size_t>(start[num_free_]));
    elements.shrink_to_fit();
    start.pop_back();
  });
}

void BlockAssembler::build_slots() const {
  build_pattern();
  std::call_once(slots_once_, [&] {
    const BBSpace& space = *space_;
    const index_t ne = space.mesh().num_tets();
    const BlockPattern& p = *pattern_;
    // Slots: the block of every pair of an element's nodes (-1 where either is fixed).
    slots_.resize(static_cast<size_t>(ne) * n_ * n_);
    const index_t* cols = p.col_idx.data();
#pragma omp parallel for schedule(static)
    for (index_t e = 0; e < ne; ++e) {
      const index_t* nodes = space.element_nodes(e);
      offset_t* out = slots_.data() + static_cast<size_t>(e) * n_ * n_;
      index_t J[kMaxNodes];
      for (int b = 0; b < n_; ++b) J[b] = free_index_[nodes[b]];
      for (int a = 0; a < n_; ++a) {
        // Row I's sorted columns hold every J of the element (the pattern was built from them).
        const index_t I = J[a];
        const index_t* first = I >= 0 ? cols + p.row_ptr[I] : nullptr;
        const index_t* last = I >= 0 ? cols + p.row_ptr[I + 1] : nullptr;
        for (int b = 0; b < n_; ++b)
          out[a * n_ + b] = I >= 0 && J[b] >= 0 ? std::lower_bound(first, last, J[b]) - cols : -1;
      }
    }
  });
}

}  // namespace pmg::fem
