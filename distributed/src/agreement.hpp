// What the ranks of a distributed solve must agree on, as pmg::mpi::check_agreement() items.
#pragma once

#include "pmg/distributed/mgpcg.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/mpi/agreement.hpp"

#include <vector>

namespace pmg::dist::detail {

/// A double as 17 significant digits (equal strings for equal values).
std::string exact(double v);
/// The model every rank partitions: degree, levels, the mesh (vertices and elements as digests),
/// material, per-element stiffness, the fixed nodes and held components.
std::vector<mpi::Item> hierarchy_items(const fem::DegreeHierarchy& h);
/// Every key of petsc-mgpcg, by its name.
std::vector<mpi::Item> params_items(const DistributedMgpcgParams& p);

}  // namespace pmg::dist::detail
