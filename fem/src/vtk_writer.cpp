#include "pmg/fem/vtk_writer.hpp"

#include "pmg/sparse/file_io.hpp"

#include <sstream>

namespace pmg::fem {

namespace {
constexpr int kVtkBezierTetrahedron = 78;

std::vector<int> build_vtk_order(int p) {
  // VTK's tetra: edges 01, 12, 20, 03, 13, 23; faces 013, 123, 203, 021 (vtkHigherOrderTetra).
  std::vector<int> out;
  for (const auto& a : ordered_multi_indices(p, {{{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}}},
                                             {{{0, 1, 3}, {1, 2, 3}, {2, 0, 3}, {0, 2, 1}}}))
    out.push_back(local_index(a));
  return out;
}
}  // namespace

const std::vector<int>& vtk_to_local(int p) {
  static const std::vector<int> tables[3] = {build_vtk_order(1), build_vtk_order(2),
                                             build_vtk_order(3)};
  if (p < 1 || p > 3) throw InputError("VTK output: degree must be 1, 2 or 3");
  return tables[p - 1];
}

void write_vtu(const std::string& path, const BBSpace& space, const Vector& u,
               const VtuOptions& options) {
  const index_t nn = space.num_nodes(), ne = space.mesh().num_tets();
  const int n = space.nodes_per_element();
  if (u.size() != 0 && u.size() != 3 * nn)
    throw InputError("VTK output: displacement has " + std::to_string(u.size()) +
                     " entries, expected " + std::to_string(3 * nn));
  const bool deformed = options.deformed && u.size() != 0;
  std::ostringstream out;
  out.precision(17);
  out << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n<UnstructuredGrid>\n"
      << "<Piece NumberOfPoints=\"" << nn << "\" NumberOfCells=\"" << ne << "\">\n"
      << "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
  for (index_t i = 0; i < nn; ++i) {
    Vec3 x = space.positions()[i];
    if (deformed) x += u.segment<3>(3 * i);
    out << x.x() << " " << x.y() << " " << x.z() << "\n";
  }
  out << "</DataArray>\n</Points>\n<Cells>\n"
      << "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  const auto& perm = vtk_to_local(space.degree());
  for (index_t e = 0; e < ne; ++e) {
    for (int i = 0; i < n; ++i) out << space.node(e, perm[i]) << (i + 1 < n ? " " : "\n");
  }
  out << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (index_t e = 0; e < ne; ++e) out << static_cast<offset_t>(e + 1) * n << "\n";
  out << "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
  for (index_t e = 0; e < ne; ++e) out << kVtkBezierTetrahedron << "\n";
  out << "</DataArray>\n</Cells>\n";
  if (!options.fixed.empty() && options.fixed.size() != static_cast<size_t>(nn))
    throw InputError("VTK output: " + std::to_string(options.fixed.size()) + " fixed flags, expected " + std::to_string(nn));
  if (options.load.size() != 0 && options.load.size() != 3 * nn)
    throw InputError("VTK output: the load has " + std::to_string(options.load.size()) + " entries, expected " +
                     std::to_string(3 * nn));
  if (options.pressure.size() != 0 && options.pressure.size() != nn)
    throw InputError("VTK output: the pressure has " + std::to_string(options.pressure.size()) + " entries, expected " +
                     std::to_string(nn));
  const bool load = options.load.size() != 0 && options.load.cwiseAbs().maxCoeff() > 0;
  if (u.size() != 0 || !options.fixed.empty() || load || options.pressure.size() != 0) {
    out << "<PointData" << (u.size() != 0 ? " Vectors=\"displacement\"" : "") << ">\n";
    if (u.size() != 0) {
      out << "<DataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (index_t i = 0; i < nn; ++i) out << u[3 * i] << " " << u[3 * i + 1] << " " << u[3 * i + 2] << "\n";
      out << "</DataArray>\n";
    }
    if (!options.fixed.empty()) {
      out << "<DataArray type=\"UInt8\" Name=\"fixed\" format=\"ascii\">\n";
      for (index_t i = 0; i < nn; ++i) out << (options.fixed[i] ? 1 : 0) << (i + 1 < nn ? " " : "\n");
      out << "</DataArray>\n";
    }
    if (load) {
      out << "<DataArray type=\"Float64\" Name=\"load\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (index_t i = 0; i < nn; ++i)
        out << options.load[3 * i] << " " << options.load[3 * i + 1] << " " << options.load[3 * i + 2] << "\n";
      out << "</DataArray>\n";
    }
    if (options.pressure.size() != 0) {
      out << "<DataArray type=\"Float64\" Name=\"pressure\" format=\"ascii\">\n";
      for (index_t i = 0; i < nn; ++i) out << options.pressure[i] << (i + 1 < nn ? " " : "\n");
      out << "</DataArray>\n";
    }
    out << "</PointData>\n";
  }
  out << "</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  write_file_atomically(path, out.str());
}

void write_pvtu(const std::string& path, const std::vector<std::string>& pieces, bool with_displacement) {
  if (pieces.empty()) throw InputError("VTK output: a .pvtu needs at least one piece");
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n<PUnstructuredGrid GhostLevel=\"0\">\n";
  if (with_displacement)
    out << "<PPointData Vectors=\"displacement\">\n"
        << "<PDataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\"/>\n</PPointData>\n";
  out << "<PPoints>\n<PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n</PPoints>\n"
      << "<PCells>\n<PDataArray type=\"Int64\" Name=\"connectivity\"/>\n"
      << "<PDataArray type=\"Int64\" Name=\"offsets\"/>\n<PDataArray type=\"UInt8\" Name=\"types\"/>\n</PCells>\n";
  for (const std::string& piece : pieces) out << "<Piece Source=\"" << piece << "\"/>\n";
  out << "</PUnstructuredGrid>\n</VTKFile>\n";
  write_file_atomically(path, out.str());
}

void write_pvd(const std::string& path, const std::vector<std::pair<double, std::string>>& frames) {
  std::ostringstream out;
  out.precision(17);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
  for (const auto& [t, file] : frames)
    out << "<DataSet timestep=\"" << t << "\" part=\"0\" file=\"" << file << "\"/>\n";
  out << "</Collection>\n</VTKFile>\n";
  write_file_atomically(path, out.str());
}

}  // namespace pmg::fem
