// pmg/fem/mesh_io.hpp — tetrahedral mesh readers (Gmsh .msh 4.1 and 2.2 ASCII, TetGen .node/.ele)
// and closed-surface readers (.off, ASCII/binary .stl) for meshing.
//
// Errors name the file, the line and what is wrong. Readers keep only tetrahedra: nodes used by
// no tetrahedron (surface-only, higher-order) are dropped, higher-order tetrahedra keep their four
// corners (with a warning), and negatively oriented tetrahedra are reordered. The result has passed
// check_mesh().
#pragma once

#include "pmg/fem/mesh.hpp"

#include <iosfwd>
#include <string>
#include <vector>

namespace pmg::fem {

/// Reads .msh (Gmsh), or .node/.ele (TetGen: give either file or the common base name).
/// `options` are check_mesh()'s (orientation is always fixed); its `allow` flags let a user accept
/// a tangled or cracked mesh on purpose.
TetMesh read_mesh(const std::string& path, std::vector<std::string>* warnings = nullptr,
                  const MeshCheckOptions& options = {});
/// Reads a Gmsh .msh file (format 2.2 or 4.1, ASCII), as read_mesh().
TetMesh read_gmsh(const std::string& path, std::vector<std::string>* warnings = nullptr,
                  const MeshCheckOptions& options = {});
/// Reads TetGen's BASE.node and BASE.ele, as read_mesh().
TetMesh read_tetgen(const std::string& base, std::vector<std::string>* warnings = nullptr,
                    const MeshCheckOptions& options = {});
/// The same from streams; `name` (`node_name`, `ele_name`) names the input in every message.
/// Counts read from a seekable stream are checked against its remaining size before anything is
/// allocated.
TetMesh read_gmsh(std::istream& in, const std::string& name, std::vector<std::string>* warnings = nullptr,
                  const MeshCheckOptions& options = {});
/// TetGen's .node and .ele from two streams (see read_gmsh() from a stream).
TetMesh read_tetgen(std::istream& node, const std::string& node_name, std::istream& ele,
                    const std::string& ele_name, std::vector<std::string>* warnings = nullptr,
                    const MeshCheckOptions& options = {});

/// Writes TetGen .node/.ele (1-based), atomically.
void write_tetgen(const std::string& base, const TetMesh& mesh);

/// A closed triangle surface.
struct Surface {
  /// Vertex positions.
  std::vector<Vec3> vertices;
  /// Three vertex ids per triangle (outward orientation gives a positive volume()).
  std::vector<std::array<index_t, 3>> triangles;
  /// Enclosed volume by the divergence theorem (positive for outward-oriented triangles).
  double volume() const;
};
Surface read_surface(const std::string& path);  ///< .off or .stl
/// An OFF surface from a stream; `name` stands for the file in messages.
Surface read_off(std::istream& in, const std::string& name);
Surface read_stl(std::istream& in, const std::string& name);  ///< ASCII or binary (needs seeking)

}  // namespace pmg::fem
