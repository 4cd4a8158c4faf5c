#include "pmg/fem/vtk_writer.hpp"

#include "pmg/sparse/file_io.hpp"

#include <cstdint>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

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

namespace {
/// Appends `bytes` bytes at `data` to `out` in base64 (RFC 4648, padded).
void append_base64(std::string& out, const unsigned char* data, size_t bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const size_t at = out.size();
  out.resize(at + 4 * ((bytes + 2) / 3));
  char* o = out.data() + at;
  size_t i = 0;
  for (; i + 3 <= bytes; i += 3, o += 4) {
    const unsigned v = (unsigned{data[i]} << 16) | (unsigned{data[i + 1]} << 8) | data[i + 2];
    o[0] = kAlphabet[v >> 18], o[1] = kAlphabet[(v >> 12) & 63], o[2] = kAlphabet[(v >> 6) & 63], o[3] = kAlphabet[v & 63];
  }
  if (i < bytes) {
    const unsigned v = (unsigned{data[i]} << 16) | (i + 1 < bytes ? unsigned{data[i + 1]} << 8 : 0u);
    o[0] = kAlphabet[v >> 18], o[1] = kAlphabet[(v >> 12) & 63];
    o[2] = i + 1 < bytes ? kAlphabet[(v >> 6) & 63] : '=';
    o[3] = '=';
  }
}

/// One <DataArray> in VTK's inline binary format: the byte count (UInt64, the file's header_type)
/// and the little-endian values, each base64-encoded, as VTK's own XML writer lays them out.
template <class T>
void append_array(std::string& out, const char* type, const std::string& name, int components, const T* values,
                  size_t count) {
  static_assert(std::is_arithmetic_v<T>);
  out += "<DataArray type=\"";
  out += type;
  out += '"';
  if (!name.empty()) out += " Name=\"" + name + '"';
  if (components > 1) out += " NumberOfComponents=\"" + std::to_string(components) + '"';
  out += " format=\"binary\">\n";
  const std::uint64_t bytes = sizeof(T) * count;
  append_base64(out, reinterpret_cast<const unsigned char*>(&bytes), sizeof bytes);
  append_base64(out, reinterpret_cast<const unsigned char*>(values), bytes);
  out += "\n</DataArray>\n";
}
}  // namespace

void write_vtu(const std::string& path, const BBSpace& space, const Vector& u,
               const VtuOptions& options) {
  static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "VTK output is written little-endian");
  const index_t nn = space.num_nodes(), ne = space.mesh().num_tets();
  const int n = space.nodes_per_element();
  if (u.size() != 0 && u.size() != 3 * nn)
    throw InputError("VTK output: displacement has " + std::to_string(u.size()) +
                     " entries, expected " + std::to_string(3 * nn));
  if (!options.fixed.empty() && options.fixed.size() != static_cast<size_t>(nn))
    throw InputError("VTK output: " + std::to_string(options.fixed.size()) + " fixed flags, expected " + std::to_string(nn));
  if (options.load.size() != 0 && options.load.size() != 3 * nn)
    throw InputError("VTK output: the load has " + std::to_string(options.load.size()) + " entries, expected " +
                     std::to_string(3 * nn));
  if (options.pressure.size() != 0 && options.pressure.size() != nn)
    throw InputError("VTK output: the pressure has " + std::to_string(options.pressure.size()) + " entries, expected " +
                     std::to_string(nn));
  const bool deformed = options.deformed && u.size() != 0;
  std::string out;
  out += "<?xml version=\"1.0\"?>\n"
         "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n<UnstructuredGrid>\n";
  out += "<Piece NumberOfPoints=\"" + std::to_string(nn) + "\" NumberOfCells=\"" + std::to_string(ne) + "\">\n";
  {
    std::vector<double> x(3 * static_cast<size_t>(nn));
    for (index_t i = 0; i < nn; ++i) {
      Vec3 xi = space.positions()[i];
      if (deformed) xi += u.segment<3>(3 * i);
      for (int c = 0; c < 3; ++c) x[3 * static_cast<size_t>(i) + c] = xi[c];
    }
    out += "<Points>\n";
    append_array(out, "Float64", "", 3, x.data(), x.size());
    out += "</Points>\n";
  }
  {
    const auto& perm = vtk_to_local(space.degree());
    std::vector<std::int64_t> connectivity(static_cast<size_t>(ne) * n), offsets(static_cast<size_t>(ne));
    for (index_t e = 0; e < ne; ++e) {
      for (int i = 0; i < n; ++i) connectivity[static_cast<size_t>(e) * n + i] = space.node(e, perm[i]);
      offsets[static_cast<size_t>(e)] = static_cast<std::int64_t>(e + 1) * n;
    }
    out += "<Cells>\n";
    const std::vector<std::uint8_t> types(static_cast<size_t>(ne), kVtkBezierTetrahedron);
    append_array(out, "Int64", "connectivity", 1, connectivity.data(), connectivity.size());
    append_array(out, "Int64", "offsets", 1, offsets.data(), offsets.size());
    append_array(out, "UInt8", "types", 1, types.data(), types.size());
    out += "</Cells>\n";
  }
  const bool load = options.load.size() != 0 && options.load.cwiseAbs().maxCoeff() > 0;
  if (u.size() != 0 || !options.fixed.empty() || load || options.pressure.size() != 0) {
    out += u.size() != 0 ? "<PointData Vectors=\"displacement\">\n" : "<PointData>\n";
    auto values = [](const Vector& v) { return static_cast<size_t>(v.size()); };
    if (u.size() != 0) append_array(out, "Float64", "displacement", 3, u.data(), values(u));
    if (!options.fixed.empty()) {
      std::vector<std::uint8_t> fixed(options.fixed.size());
      for (size_t i = 0; i < fixed.size(); ++i) fixed[i] = options.fixed[i] ? 1 : 0;
      append_array(out, "UInt8", "fixed", 1, fixed.data(), fixed.size());
    }
    if (load) append_array(out, "Float64", "load", 3, options.load.data(), values(options.load));
    if (options.pressure.size() != 0)
      append_array(out, "Float64", "pressure", 1, options.pressure.data(), values(options.pressure));
    out += "</PointData>\n";
  }
  out += "</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  write_file_atomically(path, out);
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
