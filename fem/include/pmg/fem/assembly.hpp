// pmg/fem/assembly.hpp — race-free parallel assembly of 3x3-block element matrices into BCSR.
//
// Built once per mesh, degree and set of fixed nodes (the pattern never changes): the elements'
// traversal on threads (pmg/fem/element_ranges.hpp: contiguous ranges, each node written by one
// thread) and on first need the BCSR pattern over the free nodes with each free node's elements
// (make_matrix(), build_pattern(): 8 n bytes per element) and a map from (element, local a,
// local b) to its block slot (build_slots(): 8 n² bytes per element), which a level used only
// matrix-free (its traversal for the forces) never pays, nor the slot map a degree-1 matrix
// assembled row by row. Assembly writes each block row and right-hand side entry from the thread that owns its
// node, in place, without locks, and in the same order on any number of threads.
#pragma once

#include "pmg/fem/bb_space.hpp"
#include "pmg/fem/element_ranges.hpp"
#include "pmg/sparse/bcsr.hpp"

#include <mutex>
#include <vector>

namespace pmg::fem {

/// The assembly plan of one BB space and set of fixed nodes: the BCSR pattern over the free nodes,
/// the element-to-slot map and the elements' traversal on threads (see the file comment). Holds a pointer to
/// the space, which must outlive it.
class BlockAssembler {
 public:
  /// free_index[node] = index of the node among the free nodes, or -1 for a fixed node.
  BlockAssembler(const BBSpace& space, std::vector<index_t> free_index);

  /// Number of free nodes (block rows of the matrices).
  index_t num_free() const { return num_free_; }
  /// Per node: its index among the free nodes, or -1 for a fixed node.
  const std::vector<index_t>& free_index() const { return free_index_; }
  /// A matrix on the pattern of the free nodes with all values zero (builds the pattern on first
  /// use).
  Bcsr make_matrix() const {
    build_pattern();
    return Bcsr(pattern_, std::vector<double>(9 * pattern_->nnz(), 0.0));
  }
  /// Builds the pattern and each free node's elements once (thread-safe); make_matrix() calls it.
  void build_pattern() const;
  /// Builds the pattern and the slot map once (thread-safe); every assembly calls it before it
  /// reads slot() (a row-by-row one, which searches its rows' columns, does not).
  void build_slots() const;
  /// The pattern (built on first use).
  const std::shared_ptr<const BlockPattern>& pattern() const {
    build_pattern();
    return pattern_;
  }
  /// Block slot of (local a, local b) of element e, or -1 if either node is fixed. Valid after
  /// build_slots() (unchecked: it is read in the assembly loops).
  offset_t slot(index_t e, int a, int b) const {
    return slots_[(static_cast<size_t>(e) * n_ + a) * n_ + b];
  }
  /// Offsets of each free node's elements in row_entries() (num_free() + 1 entries; built with the
  /// pattern on first use).
  const std::vector<offset_t>& row_start() const {
    build_pattern();
    return row_start_;
  }
  /// Per free node I, the elements that hold it as e n + a (element e, local node a), in element
  /// order: row_entries()[row_start()[I] .. row_start()[I + 1]) (built with the pattern on first
  /// use). A row-by-row assembly reads them: each block row written by one thread, summed in
  /// element order.
  const std::vector<offset_t>& row_entries() const {
    build_pattern();
    return row_entries_;
  }
  /// The elements' traversal on threads: assembly loops run ranges().for_each().
  const ElementRanges& ranges() const { return ranges_; }

 private:
  const BBSpace* space_;
  int n_;
  std::vector<index_t> free_index_;
  index_t num_free_ = 0;
  mutable std::once_flag pattern_once_, slots_once_;
  mutable std::shared_ptr<const BlockPattern> pattern_;
  mutable std::vector<offset_t> slots_;
  mutable std::vector<offset_t> row_start_, row_entries_;
  ElementRanges ranges_;
};

}  // namespace pmg::fem
