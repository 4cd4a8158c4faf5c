// pmg/fem/generators.hpp — structured tetrahedral meshes.
#pragma once

#include "pmg/fem/mesh.hpp"

namespace pmg::fem {

/// The seed's bar: nx x ny x nz boxes over [0,lx] x [0,ly] x [0,lz], each split into 24
/// tetrahedra (every face into 4 triangles through its centre, each joined to the box centre).
/// Neighbouring boxes share corner and face-centre vertices, so the mesh is conforming, and the
/// centre of every box face (e.g. the middle of the bar's free end for ny = nz = 1) is a vertex.
TetMesh box_mesh_24(index_t nx, index_t ny, index_t nz, double lx, double ly, double lz);

}  // namespace pmg::fem
