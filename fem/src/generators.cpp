#include "pmg/fem/generators.hpp"

#include "pmg/sparse/file_io.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>

namespace pmg::fem {

TetMesh box_mesh_24(index_t nx, index_t ny, index_t nz, double lx, double ly, double lz) {
  if (nx < 1 || ny < 1 || nz < 1) throw MeshError("box mesh: need at least one box per direction");
  if (!(lx > 0 && ly > 0 && lz > 0) || !std::isfinite(lx) || !std::isfinite(ly) || !std::isfinite(lz))
    throw MeshError("box mesh: side lengths must be positive and finite");
  // The half-steps l / 2n and their product (an element volume's scale): normal numbers.
  const double hv = lx / (2.0 * nx) * (ly / (2.0 * ny)) * (lz / (2.0 * nz));
  if (!std::isfinite(hv)) throw MeshError("box mesh: the boxes are too large for double precision (their volume overflows)");
  if (!std::isnormal(lx / (2.0 * nx)) || !std::isnormal(ly / (2.0 * ny)) || !std::isnormal(lz / (2.0 * nz)) ||
      !std::isnormal(hv))
    throw MeshError("box mesh: the boxes are too small for double precision (their volume underflows)");
  // Refused before anything is allocated: more elements than index_t numbers, or more memory than
  // the machine has (the mesh with its vertex map: a peak of 1.14 kB a box, measured on 100 x 100 x 10).
  const double boxes = static_cast<double>(nx) * ny * nz;
  char what[160];
  std::snprintf(what, sizeof what, "box mesh: %d x %d x %d boxes, %.3g tetrahedra", nx, ny, nz, 24 * boxes);
  if (24 * boxes > 2147483647.0) throw MeshError(std::string(what) + ": more than a 32-bit index can number");
  require_memory(1.2e3 * boxes, what);
  TetMesh m;
  // Vertices on a half-step lattice: (2i, 2j, 2k) corners, face and box centres have odd entries.
  std::map<std::tuple<index_t, index_t, index_t>, index_t> ids;
  const double hx = lx / (2.0 * nx), hy = ly / (2.0 * ny), hz = lz / (2.0 * nz);
  auto vertex = [&](index_t a, index_t b, index_t c) {
    auto [it, inserted] = ids.emplace(std::make_tuple(a, b, c), m.num_vertices());
    if (inserted) m.vertices.emplace_back(a * hx, b * hy, c * hz);
    return it->second;
  };
  for (index_t k = 0; k < nz; ++k)
    for (index_t j = 0; j < ny; ++j)
      for (index_t i = 0; i < nx; ++i) {
        const index_t cx = 2 * i + 1, cy = 2 * j + 1, cz = 2 * k + 1;
        const index_t centre = vertex(cx, cy, cz);
        // Six faces: axis d, side s = -1/+1. Corners listed counter-clockwise seen from outside.
        for (int d = 0; d < 3; ++d)
          for (int s = -1; s <= 1; s += 2) {
            index_t fc[3] = {cx, cy, cz};
            fc[d] += s;
            const index_t face_centre = vertex(fc[0], fc[1], fc[2]);
            const int u = (d + 1) % 3, v = (d + 2) % 3;
            const int du[4] = {-1, 1, 1, -1}, dv[4] = {-1, -1, 1, 1};
            index_t corner[4];
            for (int q = 0; q < 4; ++q) {
              index_t p[3];
              p[d] = fc[d];
              p[u] = fc[u] + du[q];
              p[v] = fc[v] + dv[q];
              corner[q] = vertex(p[0], p[1], p[2]);
            }
            for (int q = 0; q < 4; ++q) {
              Tet t{centre, face_centre, corner[q], corner[(q + 1) % 4]};
              m.tets.push_back(t);
            }
          }
      }
  // Orientation depends on the face side; fix it rather than reason about each case.
  for (index_t e = 0; e < m.num_tets(); ++e)
    if (m.signed_volume(e) < 0) std::swap(m.tets[e][2], m.tets[e][3]);
  return m;
}

}  // namespace pmg::fem
