// Internal to pmg::fem: a counting sort by row, the array-with-offsets form of "for each node, its
// elements" (the colouring) and "for each vertex, its edges and faces" (the node numbering).
#pragma once

#include "pmg/sparse/types.hpp"

#include <utility>
#include <vector>

namespace pmg::fem::detail {

/// Groups values by row: entry(i, k) gives {row, value} for the k < per_item entries of each item
/// i < items. `start` gets the offsets of rows [0, rows) into `values`; each row holds its values in
/// the order of their items (a stable counting sort). entry is called twice per entry.
template <typename V, typename Entry>
void group_by_row(index_t rows, index_t items, int per_item, const Entry& entry, std::vector<offset_t>& start,
                  std::vector<V>& values) {
  start.assign(static_cast<size_t>(rows) + 1, 0);
  for (index_t i = 0; i < items; ++i)
    for (int k = 0; k < per_item; ++k) ++start[entry(i, k).first + 1];
  for (index_t r = 0; r < rows; ++r) start[r + 1] += start[r];
  std::vector<offset_t> fill(start.begin(), start.end() - 1);
  values.resize(static_cast<size_t>(start[rows]));
  for (index_t i = 0; i < items; ++i)
    for (int k = 0; k < per_item; ++k) {
      const auto [row, value] = entry(i, k);
      values[fill[row]++] = value;
    }
}

}  // namespace pmg::fem::detail
