// pmg/metis/partition.hpp — the element partition of a tetrahedral mesh by METIS (Karypis and
// Kumar, "A fast and high quality multilevel scheme for partitioning irregular graphs", 1998): the
// dual graph joins elements that share a face (METIS_PartMeshDual with ncommon = 3), cut into
// parts of equal element counts with the fewest cut faces. Deterministic: a fixed seed, so every
// run (and every rank that calls it on the same mesh) gets the same parts.
#pragma once

#include "pmg/sparse/types.hpp"

#include <array>
#include <vector>

namespace pmg::metis {

/// The part (0 .. parts-1) of each element of a mesh of `num_vertices` vertices; parts = 1 gives
/// all zeros without calling METIS. Throws InputError when parts < 1, when there are fewer elements
/// than parts or an element names a vertex out of range, and Error when METIS fails or leaves a
/// part empty (a mesh in pieces can do that).
std::vector<int> partition_elements(const std::vector<std::array<index_t, 4>>& tets, index_t num_vertices,
                                     int parts);

}  // namespace pmg::metis
