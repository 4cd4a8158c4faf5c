#include "surface_simplify.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <unordered_map>

namespace pmg::tools {

fem::Surface simplify_surface(const fem::Surface& surface, size_t triangles) {
  using Kernel = CGAL::Simple_cartesian<double>;
  using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
  Mesh mesh;
  std::vector<Mesh::Vertex_index> v;
  v.reserve(surface.vertices.size());
  for (const fem::Vec3& x : surface.vertices) v.push_back(mesh.add_vertex({x.x(), x.y(), x.z()}));
  for (const auto& t : surface.triangles)
    if (mesh.add_face(v[t[0]], v[t[1]], v[t[2]]) == Mesh::null_face())
      throw InputError("surface is not a manifold triangle mesh (a face could not be added)");
  if (!CGAL::is_closed(mesh)) throw InputError("surface is not closed");
  // A closed triangle mesh has 3/2 edges per triangle.
  CGAL::Surface_mesh_simplification::Count_stop_predicate<Mesh> stop(triangles * 3 / 2);
  CGAL::Surface_mesh_simplification::edge_collapse(mesh, stop);
  mesh.collect_garbage();

  fem::Surface out;
  std::unordered_map<Mesh::Vertex_index, index_t> id;
  for (Mesh::Vertex_index vi : mesh.vertices()) {
    const auto& p = mesh.point(vi);
    id[vi] = static_cast<index_t>(out.vertices.size());
    out.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (Mesh::Face_index f : mesh.faces()) {
    std::array<index_t, 3> t;
    int k = 0;
    for (Mesh::Vertex_index vi : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) t[k++] = id[vi];
    out.triangles.push_back(t);
  }
  return out;
}

}  // namespace pmg::tools
