// The multigrid benchmarks' system: a unit cube of n^3 boxes of 24 tetrahedra, clamped at z = 0,
// its degree hierarchy assembled (static stiffness).
#pragma once

#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"

#include <memory>

namespace pmg::bench {

/// The cube's mesh and its assembled degree hierarchy (the hierarchy refers to the mesh).
struct ClampedCube {
  fem::TetMesh mesh;
  std::unique_ptr<fem::DegreeHierarchy> h;
  ClampedCube(int boxes, int degree) : mesh(fem::box_mesh_24(boxes, boxes, boxes, 1.0, 1.0, 1.0)) {
    h = std::make_unique<fem::DegreeHierarchy>(mesh, degree, fem::Material{1e6, 0.3, 1000.0},
                                               [](const fem::Vec3& X) { return X.z() < 1e-12; });
    h->assemble(nullptr);
  }
};

}  // namespace pmg::bench
