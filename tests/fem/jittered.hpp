// Test inputs shared by the fem tests: a box of 24-tet cells (1.0 x 0.8 x 0.6) with its interior
// vertices moved (general element shapes) and a smooth test vector.
#pragma once

#include "pmg/fem/generators.hpp"

#include <cmath>

namespace pmg::fem::test {

/// nx x ny x nz cells; interior vertex i moves by amplitude (sin 3i, cos 5i, sin(7i + 1)).
inline TetMesh jittered_box(int nx = 2, int ny = 2, int nz = 2, double amplitude = 0.04) {
  TetMesh m = box_mesh_24(nx, ny, nz, 1.0, 0.8, 0.6);
  for (size_t i = 0; i < m.vertices.size(); ++i) {
    Vec3& X = m.vertices[i];
    const bool interior = X[0] > 1e-9 && X[0] < 1.0 - 1e-9 && X[1] > 1e-9 && X[1] < 0.8 - 1e-9 &&
                          X[2] > 1e-9 && X[2] < 0.6 - 1e-9;
    if (interior) X += amplitude * Vec3(std::sin(3.0 * i), std::cos(5.0 * i), std::sin(7.0 * i + 1));
  }
  return m;
}

/// A smooth, non-constant test vector of n entries: sin(0.37 i + phase) + 0.3 cos(1.3 i).
inline Vector smooth_vector(index_t n, double phase) {
  Vector v(n);
  for (index_t i = 0; i < n; ++i) v[i] = std::sin(0.37 * i + phase) + 0.3 * std::cos(1.3 * i);
  return v;
}

}  // namespace pmg::fem::test
