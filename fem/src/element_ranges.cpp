#include "pmg/fem/element_ranges.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <utility>

namespace pmg::fem {

namespace {
/// Ranges the decision between the elements' own order and the Morton order is made for: a fixed
/// number, so that the traversal (and with it every sum's order) does not depend on the threads.
constexpr int kProbeRanges = 8;
}  // namespace

ElementRanges::ElementRanges(const BBSpace& space) : space_(&space), n_(space.nodes_per_element()) {
  locate_nodes();
  const index_t ne = space.mesh().num_tets();
  if (ne < 256) return;
  // The elements' own order unless more than one in eight elements would be visited twice with
  // kProbeRanges ranges.
  index_t twice = 0;
  for (int t = 0; t < kProbeRanges; ++t) {
    const index_t begin = range_begin(ne, t, kProbeRanges), end = range_begin(ne, t + 1, kProbeRanges);
    const Writes own{first_.data(), last_.data(), begin, end, false};
    for (index_t e = begin; e < end; ++e) {
      const index_t* nodes = space.element_nodes(e);
      for (int a = 0; a < n_; ++a)
        if (!own(nodes[a])) {
          ++twice;
          break;
        }
    }
  }
  if (8 * static_cast<long long>(twice) <= ne) return;

  order_ = morton_order(space.mesh());
  locate_nodes();
}

void ElementRanges::locate_nodes() {
  const index_t ne = space_->mesh().num_tets();
  first_.assign(static_cast<size_t>(space_->num_nodes()), -1);
  last_.assign(static_cast<size_t>(space_->num_nodes()), -1);
  for (index_t pos = 0; pos < ne; ++pos) {
    const index_t* nodes = space_->element_nodes(element(pos));
    for (int a = 0; a < n_; ++a) {
      const index_t node = nodes[a];
      if (first_[node] < 0) first_[node] = pos;
      last_[node] = pos;
    }
  }
}

}  // namespace pmg::fem

namespace pmg::fem {

int ElementRanges::threads() const { return space_->mesh().num_tets() >= 256 ? omp_get_max_threads() : 1; }

double ElementRanges::for_each(const Visit& visit) const {
  const index_t ne = space_->mesh().num_tets();
  const int threads = this->threads();
  std::vector<std::vector<index_t>> deferred(static_cast<size_t>(threads));
  std::vector<double> sums(static_cast<size_t>(threads), 0.0);
  std::vector<index_t> bounds(static_cast<size_t>(threads) + 1, ne);
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    const index_t begin = range_begin(ne, t, nt), end = range_begin(ne, t + 1, nt);
    bounds[static_cast<size_t>(t)] = begin;
    const Writes own{first_.data(), last_.data(), begin, end, false};
    std::vector<index_t>& later = deferred[static_cast<size_t>(t)];
    double sum = 0.0;
    for (index_t pos = begin; pos < end; ++pos) {
      const index_t e = element(pos);
      sum += visit(t, e, own, true);
      const index_t* nodes = space_->element_nodes(e);
      for (int a = 0; a < n_; ++a)
        if (!own(nodes[a])) {
          later.push_back(pos);
          break;
        }
    }
    sums[static_cast<size_t>(t)] = sum;
  }
  for (size_t t = 0; t < deferred.size(); ++t) {
    if (deferred[t].empty()) continue;
    const Writes shared{first_.data(), last_.data(), bounds[t], bounds[t + 1], true};
    for (index_t pos : deferred[t]) visit(0, element(pos), shared, false);
  }
  double total = 0.0;
  for (double s : sums) total += s;
  return total;
}

}  // namespace pmg::fem
