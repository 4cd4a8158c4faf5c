// pmg/sparse/generators.hpp — built-in test systems with known solutions (until the FEM exists).
#pragma once

#include "pmg/sparse/bcsr.hpp"

namespace pmg {

/// Elasticity-like SPD matrix on an n x n x n grid of nodes with 3 unknowns each: every node is
/// joined to its 26 neighbours (a 27-point 3x3-block stencil) by a spring of stiffness
/// (d d^T + 0.2 I)/|e| along the unit direction d of edge e, and the nodes of the z = 0 face are
/// tied to the ground by identity springs (the Dirichlet face). Condition number grows like n^2.
Bcsr spring_lattice(index_t n);

/// A smooth displacement field on the same grid (3 components per node), for manufactured
/// right-hand sides b = A x*.
Vector smooth_field(index_t n);

}  // namespace pmg
