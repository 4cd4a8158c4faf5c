// pmg/fem/element_ranges.hpp — element loops on threads that write per-node results in place:
// no colouring, no atomics, the same per-node sums on any number of threads.
//
// The elements, in a traversal order, are split into one contiguous range per thread. A node whose
// elements all lie in one range is that range's own: its thread writes it while it runs the range.
// The few elements holding a node shared by two ranges are visited once more afterwards, on one
// thread in traversal order, for the shared nodes only. Every node thus receives its elements'
// contributions in traversal order, whatever the number of threads. (A sum over the elements, an
// energy, is summed per thread and then over the threads: it rounds by thread count.)
//
// The second visits run on one thread: their share grows with the number of ranges (at most one
// element in eight for 8 ranges, by the choice of order below), so with many threads on a small
// mesh they bound the speed-up.
//
// The traversal order is the elements' own when contiguous ranges of it share few nodes (meshes
// that pmgkit makes or refines, where nodes are numbered as the elements meet them, so a range's
// writes also stay close in memory); otherwise (a mesh generator's arbitrary order) it is the
// Z-order (Morton order) of the element centroids, whose ranges are compact pieces of the mesh.
#pragma once

#include "pmg/fem/bb_space.hpp"

#include <functional>
#include <vector>

namespace pmg::fem {

/// The traversal of one BB space's elements described in the file comment. Holds a pointer to the
/// space, which must outlive it.
class ElementRanges {
 public:
  /// The traversal of the space's elements: their own order, or the Morton order where that keeps
  /// ranges apart (decided for 8 ranges, so the same on any number of threads).
  explicit ElementRanges(const BBSpace& space);

  /// Whether the traversal is the Morton order of the centroids (false: the elements' own order).
  bool reordered() const { return !order_.empty(); }
  /// The element at traversal position pos, in [0, number of elements).
  index_t element(index_t pos) const { return order_.empty() ? pos : order_[pos]; }

  /// The predicate for_each passes: whether the node's elements all lie in [begin, end) of the
  /// traversal (negated for the second visit).
  struct Writes {
    const index_t* first;  ///< per node: the first traversal position of an element holding it
    const index_t* last;   ///< per node: the last such position
    index_t begin;         ///< the range's first traversal position
    index_t end;           ///< one past its last
    bool negate;           ///< the second visit: the nodes the range does not own alone
    /// Whether the call writes this node's results.
    bool operator()(index_t node) const {
      return (first[node] >= begin && last[node] < end) != negate;
    }
  };

  /// The callback of for_each: thread lies in [0, threads()) (the second visits pass 0); it returns
  /// the element's share of a sum over the elements (an energy; 0 where there is none).
  using Visit = std::function<double(int thread, index_t e, const Writes& writes, bool first)>;

  /// Calls visit(thread, e, writes, first) once per element e with first = true, on the threads,
  /// and again with first = false for the elements that hold a node shared between ranges, on one
  /// thread. writes(node) says whether this call writes node's results: a node is written by
  /// exactly one call of each element that holds it. Per-thread scratch space is indexed by
  /// `thread`. Returns the sum of what the first calls return (per thread, then over the threads).
  double for_each(const Visit& visit) const;
  /// The number of threads for_each asks for (OpenMP's maximum at the call; 1 for meshes under 256
  /// elements); the runtime may give it fewer. Bounds the `thread` argument of visits.
  int threads() const;

 private:
  static index_t range_begin(index_t ne, int t, int nt) {
    return static_cast<index_t>(static_cast<long long>(ne) * t / nt);
  }
  /// first_/last_: per node, the first and last traversal position of an element holding it.
  void locate_nodes();

  const BBSpace* space_;
  int n_;
  std::vector<index_t> order_;  ///< traversal position -> element; empty: the identity
  std::vector<index_t> first_, last_;
};

}  // namespace pmg::fem
