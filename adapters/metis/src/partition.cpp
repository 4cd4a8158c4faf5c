// The METIS adapter (pmg/metis/partition.hpp).
#include "pmg/metis/partition.hpp"

#include <metis.h>

#include <string>

namespace pmg::metis {

std::vector<int> partition_elements(const std::vector<std::array<index_t, 4>>& tets, index_t num_vertices,
                                    int parts) {
  if (parts < 1) throw InputError("partition: " + std::to_string(parts) + " parts (at least 1)");
  const size_t ne = tets.size();
  if (ne < static_cast<size_t>(parts))
    throw InputError("partition: " + std::to_string(ne) + " elements cannot fill " + std::to_string(parts) +
                     " parts (one element per rank at least); use fewer ranks or a finer mesh");
  for (const auto& t : tets)
    for (index_t v : t)
      if (v < 0 || v >= num_vertices)
        throw InputError("partition: an element names vertex " + std::to_string(v) + " of " +
                         std::to_string(num_vertices));
  std::vector<int> part(ne, 0);
  if (parts == 1) return part;
  static_assert(sizeof(idx_t) == sizeof(index_t), "METIS's idx_t is 32-bit here");
  std::vector<idx_t> eptr(ne + 1), eind(4 * ne), epart(ne), npart(num_vertices);
  for (size_t e = 0; e < ne; ++e) {
    eptr[e] = static_cast<idx_t>(4 * e);
    for (int k = 0; k < 4; ++k) eind[4 * e + k] = tets[e][k];
  }
  eptr[ne] = static_cast<idx_t>(4 * ne);
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = 1;
  options[METIS_OPTION_NUMBERING] = 0;
  idx_t n_elements = static_cast<idx_t>(ne), n_nodes = num_vertices, ncommon = 3, nparts = parts, objval = 0;
  const int status = METIS_PartMeshDual(&n_elements, &n_nodes, eptr.data(), eind.data(), nullptr, nullptr,
                                        &ncommon, &nparts, nullptr, options, &objval, epart.data(), npart.data());
  if (status != METIS_OK)
    throw Error("partition: METIS_PartMeshDual failed (" +
                std::string(status == METIS_ERROR_MEMORY ? "out of memory" : status == METIS_ERROR_INPUT ? "bad input" : "error") + ")");
  std::vector<index_t> count(parts, 0);
  for (size_t e = 0; e < ne; ++e) {
    part[e] = static_cast<int>(epart[e]);
    if (part[e] < 0 || part[e] >= parts) throw Error("partition: METIS returned part " + std::to_string(part[e]));
    ++count[part[e]];
  }
  for (int p = 0; p < parts; ++p)
    if (count[p] == 0)
      throw Error("partition: METIS left part " + std::to_string(p) + " of " + std::to_string(parts) +
                  " empty (a mesh in pieces, or too few elements for the ranks)");
  return part;
}

}  // namespace pmg::metis
