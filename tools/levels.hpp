// Multigrid levels as files: export an FEM scene's levels in the form `pmg compare --levels`
// reads back (mg::read_levels), so PMG and MGPCG run on systems from any code.
#pragma once

#include "scene.hpp"

#include <string>

namespace pmg::tools {

/// Writes DIR/A<l>.mtx (level matrices over the free dofs, symmetric), DIR/P<l>.mtx (scalar
/// prolongations) and DIR/b.mtx; assembles the lower levels first.
void export_levels(FemSystem& system, const std::string& dir);

/// Writes the finest system in PETSc's binary format: DIR/A.petsc (the matrix over the free dofs),
/// DIR/b.petsc and DIR/coordinates.petsc (x, y, z of each free node, interleaved).
void export_petsc(const FemSystem& system, const std::string& dir);

}  // namespace pmg::tools
