// pmg/fem/vtk_writer.hpp — VTK XML output with Bézier tetrahedra (VTK_BEZIER_TETRAHEDRON = 78),
// readable by ParaView and VTK >= 9.
//
// Each element is one Bézier cell whose points are its BB control points in VTK's order (vertices;
// edge points along edges 01, 12, 20, 03, 13, 23; face points of faces 013, 123, 203, 021). The
// displacement field is written as point data; because the basis is Bernstein, its values are the
// Bézier coefficients, which is what VTK interpolates on Bézier cells. Files are written to a
// temporary name and renamed, so a reader never sees a partial file.
#pragma once

#include "pmg/fem/bb_space.hpp"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace pmg::fem {

/// Options of write_vtu().
struct VtuOptions {
  /// Write the deformed control points X + u as the geometry (else the rest positions).
  bool deformed = false;
  /// One flag per node (non-zero: the node is clamped), written as the point array "fixed"
  /// (UInt8); empty: not written. What `pmg render` draws as the clamp.
  std::vector<std::uint8_t> fixed;
  /// The external force, 3 per node, written as the point array "load" (Float64, 3 components,
  /// in N); empty or zero: not written. What `pmg render` draws as load arrows.
  Vector load;
  /// A scalar per node (the pressure of the mixed elements, raised to the space's degree: its BB
  /// coefficients), written as the point array "pressure"; empty: not written.
  Vector pressure;
};

/// Writes the mesh of `space` with the displacement u (3 per node; may be empty) as a VTK XML
/// unstructured grid of Bézier tetrahedra, every array in VTK's inline binary format (base64 of the
/// exact little-endian values, UInt64 byte counts), through a temporary file renamed at the end.
void write_vtu(const std::string& path, const BBSpace& space, const Vector& u,
               const VtuOptions& options = {});

/// The permutation from VTK's point order of a degree-p Bézier tetrahedron to local BB nodes:
/// vtk_point i is local node vtk_to_local(p)[i].
const std::vector<int>& vtk_to_local(int p);

/// Writes a parallel unstructured grid (.pvtu, ParaView's convention for a mesh written in pieces,
/// one per MPI rank) naming `pieces`: .vtu files from write_vtu(), relative to the .pvtu's folder.
/// with_displacement: the pieces carry the displacement field.
void write_pvtu(const std::string& path, const std::vector<std::string>& pieces, bool with_displacement);
/// Writes a ParaView collection (.pvd) of (time, file) frames.
void write_pvd(const std::string& path, const std::vector<std::pair<double, std::string>>& frames);

}  // namespace pmg::fem
