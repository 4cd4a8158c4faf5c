// Surface decimation for pmg mesh: TetGen keeps every input surface triangle, so a fine scan (the
// Stanford bunny has 75k triangles) must be coarsened before it can become a coarse volume mesh.
#pragma once

#include "pmg/fem/mesh_io.hpp"

namespace pmg::tools {

/// Edge-collapse simplification (CGAL, Lindstrom–Turk placement) down to about `triangles`
/// triangles. Throws InputError if the surface is not a closed triangle mesh.
fem::Surface simplify_surface(const fem::Surface& surface, size_t triangles);

}  // namespace pmg::tools
