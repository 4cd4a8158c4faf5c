// pmgkit._core, its FEM half: meshes, elasticity models, degree hierarchies and scenes (the
// solvers, formats and PETSc files are module.cpp). Arrays and errors are converted as there; the
// GIL is released during assembly, static solves and simulations.
#include "common.hpp"

#include "pmg/fem/elasticity.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/fem/locator.hpp"
#include "pmg/fem/mesh_io.hpp"
#include "pmg/fem/mixed.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/sim/run.hpp"
#include "pmg/sim/scene.hpp"
#include "pmg/sim/setup.hpp"

#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <array>
#include <cstdio>
#include <set>

namespace pmg::python {

namespace {

// ---- FEM -----------------------------------------------------------------------------------------

std::vector<fem::Vec3> points_of(const DoubleArray& a, const std::string& who) {
  if (a.ndim() != 2 || a.shape(1) != 3) throw InputError(who + ": expected an (n, 3) array");
  std::vector<fem::Vec3> p(a.shape(0));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) p[i] = fem::Vec3(a.at(i, 0), a.at(i, 1), a.at(i, 2));
  return p;
}

fem::Vec3 vec3(const std::vector<double>& v, const std::string& who) {
  if (v.size() != 3) throw InputError(who + ": expected 3 numbers");
  return fem::Vec3(v[0], v[1], v[2]);
}

py::array_t<double> points_array(const std::vector<fem::Vec3>& p) {
  py::array_t<double> a({static_cast<py::ssize_t>(p.size()), py::ssize_t(3)});
  auto m = a.mutable_unchecked<2>();
  for (size_t i = 0; i < p.size(); ++i)
    for (int d = 0; d < 3; ++d) m(i, d) = p[i][d];
  return a;
}

/// A mesh with the options it was checked under (inverted elements refused unless fixed, ...).
fem::TetMesh checked_mesh(fem::TetMesh m, bool fix_orientation) {
  fem::MeshCheckOptions o;
  o.fix_orientation = fix_orientation;
  fem::check_mesh(m, o);
  return m;
}

/// The elasticity model of one degree with its own Dirichlet set and matrices.
class PyModel {
 public:
  PyModel(std::shared_ptr<const fem::TetMesh> mesh, int degree, const fem::Material& material)
      : mesh_(std::move(mesh)) {
    if (degree < 1 || degree > 3) throw InputError("degree must be 1, 2 or 3, got " + std::to_string(degree));
    material.check();
    model_ = std::make_unique<fem::ElasticityModel>(*mesh_, degree, material);
  }
  fem::ElasticityModel& m() { return *model_; }
  const fem::PointLocator& locator() {
    if (!locator_) locator_ = std::make_unique<fem::PointLocator>(*model_);
    return *locator_;
  }

 private:
  std::shared_ptr<const fem::TetMesh> mesh_;
  std::unique_ptr<fem::ElasticityModel> model_;
  std::unique_ptr<fem::PointLocator> locator_;
};

py::array_t<double> node_positions(const fem::ElasticityModel& m) {
  return points_array(m.space().positions());
}

/// A predicate's answer by its truth value (bools, numbers, NumPy scalars, one-element arrays);
/// None, strings and values without one truth value (arrays of several entries) are an InputError
/// naming `who` and what it returned.
bool predicate_answer(const py::object& r, const char* who) {
  const auto refuse = [&] {
    throw InputError(std::string(who) + ": the function must return True or False, it returned " +
                     std::string(py::str(py::type::of(r).attr("__name__"))) + " " + std::string(py::repr(r)).substr(0, 60));
  };
  if (r.is_none() || py::isinstance<py::str>(r) || py::isinstance<py::bytes>(r)) refuse();
  const int t = PyObject_IsTrue(r.ptr());  // numbers, NumPy scalars and one-element arrays by truth value
  if (t < 0) {
    PyErr_Clear();  // an array of several entries, or a truth value that raises
    refuse();
  }
  return t != 0;
}

std::vector<char> clamp_mask(const fem::TetMesh& mesh, py::object clamp) {
  std::vector<char> mask(mesh.num_vertices(), 0);
  if (clamp.is_none()) return mask;
  if (PyCallable_Check(clamp.ptr())) {
    for (index_t v = 0; v < mesh.num_vertices(); ++v)
      mask[v] = predicate_answer(clamp(points_array({mesh.vertices[v]})[py::make_tuple(0)]), "clamp");
    return mask;
  }
  const auto a = clamp.cast<py::array_t<bool, py::array::c_style | py::array::forcecast>>();
  if (a.ndim() != 1 || a.shape(0) != mesh.num_vertices())
    throw InputError("clamp: expected one boolean per mesh vertex (" + std::to_string(mesh.num_vertices()) + ") or a function of a position");
  for (index_t v = 0; v < mesh.num_vertices(); ++v) mask[v] = a.at(v);
  return mask;
}

/// Components held per vertex: None (empty: none) or an (n_vertices, 3) boolean array, column c
/// set where component c is held at zero (bits 1, 2, 4 of constrain_components' masks).
std::vector<char> component_masks(const fem::TetMesh& mesh, py::object held) {
  if (held.is_none()) return {};
  const auto a = held.cast<py::array_t<bool, py::array::c_style | py::array::forcecast>>();
  if (a.ndim() != 2 || a.shape(0) != mesh.num_vertices() || a.shape(1) != 3)
    throw InputError("components: expected an (n_vertices, 3) boolean array (" + std::to_string(mesh.num_vertices()) +
                     " vertices; column c: component c held at zero)");
  std::vector<char> masks(mesh.num_vertices(), 0);
  for (index_t v = 0; v < mesh.num_vertices(); ++v)
    for (int c = 0; c < 3; ++c)
      if (a.at(v, c)) masks[v] = static_cast<char>(masks[v] | (1 << c));
  return masks;
}

py::dict run_records(const sim::RunSummary& r) {
  const size_t n = r.records.size();
  auto column = [&](auto get) {
    py::array_t<double> a(n);
    auto m = a.mutable_unchecked<1>();
    for (size_t i = 0; i < n; ++i) m(i) = get(r.records[i]);
    return a;
  };
  py::dict d;
  d["step"] = column([](const sim::StepRecord& s) { return double(s.step); });
  d["time"] = column([](const sim::StepRecord& s) { return s.time; });
  py::array_t<double> probe({static_cast<py::ssize_t>(n), py::ssize_t(3)});
  auto pm = probe.mutable_unchecked<2>();
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) pm(i, k) = r.records[i].probe[k];
  d["probe"] = probe;
  d["kinetic"] = column([](const sim::StepRecord& s) { return s.kinetic; });
  d["elastic"] = column([](const sim::StepRecord& s) { return s.elastic; });
  d["total_energy"] = column([](const sim::StepRecord& s) { return s.total_energy; });
  d["iterations"] = column([](const sim::StepRecord& s) { return double(s.iterations); });
  d["rel_residual"] = column([](const sim::StepRecord& s) { return s.rel_residual; });
  d["residual"] = column([](const sim::StepRecord& s) { return s.residual; });
  for (int k = 0; k < fem::kNumStages; ++k)
    d[(std::string(fem::stage_name(k)) + "_s").c_str()] = column([k](const sim::StepRecord& s) { return s.stage_s[k]; });
  return d;
}

}  // namespace

namespace {

/// Material and Mesh.
void register_mesh(py::module_& m) {
  py::class_<fem::Material>(m, "Material", "A linear elastic material: Young's modulus [Pa], Poisson's ratio, density [kg/m^3].")
      .def(py::init([](double young, double poisson, double density) {
             fem::Material mat{young, poisson, density};
             mat.check();
             return mat;
           }),
           py::arg("young") = 500e3, py::arg("poisson") = 0.3, py::arg("density") = 1e3,
           "young: Young's modulus [Pa] (> 0); poisson: Poisson's ratio (in (-1, 0.5)); density [kg/m^3] "
           "(>= 0). Raises InputError for values out of range.")
      .def_readonly("young", &fem::Material::young, "Young's modulus [Pa].")
      .def_readonly("poisson", &fem::Material::poisson, "Poisson's ratio.")
      .def_readonly("density", &fem::Material::density, "Density [kg/m^3].")
      .def("__repr__", [](const fem::Material& mat) {
        char text[160];
        std::snprintf(text, sizeof text, "<pmgkit.Material: young %g Pa, poisson %g, density %g kg/m^3>", mat.young,
                      mat.poisson, mat.density);
        return std::string(text);
      });

  py::class_<fem::TetMesh, std::shared_ptr<fem::TetMesh>>(m, "Mesh",
                                                          "A tetrahedral mesh (vertices and 4-vertex elements), "
                                                          "checked when built: degenerate or inverted elements are "
                                                          "refused.")
      .def(py::init([](const DoubleArray& vertices, const py::object& tets_obj, bool fix_orientation) {
             fem::TetMesh mesh;
             mesh.vertices = points_of(vertices, "vertices");
             const py::array tets_in = py::module_::import("numpy").attr("asarray")(tets_obj);
             const char kind = tets_in.dtype().kind();
             if (kind != 'i' && kind != 'u')  // floats would be truncated to vertex numbers silently
               throw InputError("tets: expected an integer array, got " + std::string(py::str(tets_in.dtype())));
             const auto tets = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(tets_in);
             if (!tets) throw InputError("tets: expected an (m, 4) integer array");
             if (tets.ndim() != 2 || tets.shape(1) != 4) throw InputError("tets: expected an (m, 4) integer array");
             for (py::ssize_t e = 0; e < tets.shape(0); ++e) {
               fem::Tet t;
               for (int k = 0; k < 4; ++k) {
                 const long long v = tets.at(e, k);
                 if (v < 0 || v >= static_cast<long long>(mesh.vertices.size()))
                   throw InputError("tets: element " + std::to_string(e) + " names vertex " + std::to_string(v) +
                                    ", the mesh has " + std::to_string(mesh.vertices.size()));
                 t[k] = static_cast<index_t>(v);
               }
               mesh.tets.push_back(t);
             }
             return std::make_shared<fem::TetMesh>(checked_mesh(std::move(mesh), fix_orientation));
           }),
           py::arg("vertices"), py::arg("tets"), py::arg("fix_orientation") = false,
           "vertices: an (n, 3) array of positions; tets: an (m, 4) integer array of vertex numbers. "
           "fix_orientation: reorder inverted elements instead of refusing them. Raises InputError for bad "
           "shapes, vertex numbers out of range or invalid elements.")
      .def_static("read", [](const std::string& path) {
        return std::make_shared<fem::TetMesh>(checked_mesh(fem::read_mesh(path), false));
      }, py::arg("path"),
         "A mesh from a Gmsh .msh file (format 2.2 or 4.1, ASCII) or TetGen's .node/.ele (either file or their "
         "base name). Raises InputError naming the file when it is malformed.")
      .def_static("box", [](int nx, int ny, int nz, double lx, double ly, double lz) {
        return std::make_shared<fem::TetMesh>(fem::box_mesh_24(nx, ny, nz, lx, ly, lz));
      }, py::arg("nx"), py::arg("ny"), py::arg("nz"), py::arg("lx") = 1.0, py::arg("ly") = 1.0, py::arg("lz") = 1.0,
         "A box [0, lx] x [0, ly] x [0, lz] of nx x ny x nz boxes, each split into 24 tetrahedra through its "
         "face centres and its centre (conforming; every box face's centre is a vertex).")
      .def("reordered_for_locality", [](const fem::TetMesh& mesh) {
        return std::make_shared<fem::TetMesh>(fem::reorder_for_locality(mesh));
      }, "The same mesh with its elements in the Z-order (Morton order) of their centroids and its vertices "
         "numbered in the order those elements first meet them: neighbours close together in memory, which "
         "multi-threaded products need (pmg does this to every mesh file it reads). Answers are unchanged up "
         "to rounding; element and vertex numbers change.")
      .def_property_readonly("vertices", [](const fem::TetMesh& mesh) { return points_array(mesh.vertices); },
                             "Vertex positions, an (n, 3) array (a copy).")
      .def_property_readonly("tets", [](const fem::TetMesh& mesh) {
        py::array_t<index_t> a({static_cast<py::ssize_t>(mesh.num_tets()), py::ssize_t(4)});
        auto w = a.mutable_unchecked<2>();
        for (index_t e = 0; e < mesh.num_tets(); ++e)
          for (int k = 0; k < 4; ++k) w(e, k) = mesh.tets[e][k];
        return a;
      }, "Elements, an (m, 4) array of vertex numbers (a copy).")
      .def_property_readonly("num_vertices", &fem::TetMesh::num_vertices, "Number of vertices.")
      .def_property_readonly("num_tets", &fem::TetMesh::num_tets, "Number of tetrahedra.")
      .def("__repr__", [](const fem::TetMesh& mesh) {
        return "<pmgkit.Mesh: " + grouped(mesh.num_vertices()) + " vertices, " + grouped(mesh.num_tets()) +
               " tetrahedra>";
      });
}

/// ElasticModel: one degree's model, its matrices, loads and static solves.
void register_model(py::module_& m) {
  py::class_<PyModel>(m, "ElasticModel",
                      "Linear elasticity of one Bernstein-Bezier degree (1, 2 or 3) on a mesh: its nodes, "
                      "Dirichlet conditions, matrices over the free dofs, loads and static solves. Full vectors "
                      "hold 3 entries per node (x, y, z interleaved), free vectors 3 per free node.")
      .def(py::init<std::shared_ptr<const fem::TetMesh>, int, const fem::Material&>(), py::arg("mesh"),
           py::arg("degree"), py::arg("material") = fem::Material{},
           "The model of `degree` (1, 2 or 3) on `mesh` with `material`; no node fixed yet. Raises InputError "
           "for another degree or a material out of range.")
      .def_property_readonly("num_nodes", [](PyModel& s) { return s.m().num_nodes(); }, "BB nodes (control points).")
      .def_property_readonly("num_dofs", [](PyModel& s) { return s.m().num_dofs(); },
                             "Unknowns of a full vector: 3 per node.")
      // Counted, not read from the assembler: building it would freeze the Dirichlet set (fix_* refused after).
      .def_property_readonly("num_free_dofs", [](PyModel& s) { return 3 * (s.m().num_nodes() - s.m().num_fixed()); },
                             "Unknowns of a free vector: 3 per node not fixed (the matrices' size).")
      .def_property_readonly("degree", [](PyModel& s) { return s.m().space().degree(); }, "The polynomial degree.")
      .def("node_positions", [](PyModel& s) { return node_positions(s.m()); },
           "Rest positions of every node, an (num_nodes, 3) array.")
      .def("fix_nodes", [](PyModel& s, std::vector<index_t> nodes) {
        for (index_t a : nodes)
          if (a < 0 || a >= s.m().num_nodes()) throw InputError("fix_nodes: node " + std::to_string(a) + " out of range");
        s.m().fix_nodes(nodes);
      }, py::arg("nodes"),
         "Fixes the given nodes (numbers in [0, num_nodes)) at zero displacement. Call before the first "
         "assembly; raises InputError for a node out of range.")
      .def("fix_vertices", [](PyModel& s, py::object clamp) { s.m().fix_vertices(clamp_mask(s.m().space().mesh(), clamp)); },
           py::arg("clamp"),
           "Fixes every node whose support (vertex, edge, face or element) has only clamped vertices. clamp: one "
           "boolean per mesh vertex, or a function of a vertex position (an array of 3) returning True or "
           "False.")
      .def("constrain_components", [](PyModel& s, py::object masks) {
        s.m().constrain_components(component_masks(s.m().space().mesh(), masks));
      }, py::arg("components"),
         "Holds single components at zero (symmetry planes, rollers): components is an (n_vertices, 3) boolean "
         "array, column c set where component c is held; a node gets it where every vertex of its support has "
         "it. Those components become identity rows of the matrices and zeros of free vectors.")
      .def_property_readonly("num_fixed", [](PyModel& s) { return s.m().num_fixed(); }, "Nodes fixed.")
      .def("stiffness", [](PyModel& s) {
        Bcsr K = s.m().assembler().make_matrix();
        {
          py::gil_scoped_release nogil;
          s.m().assemble(nullptr, Vector(), K, nullptr);
        }
        return bsr_copy(K);
      }, "The stiffness matrix over the free dofs (3x3 blocks, interleaved); pmgkit returns it as SciPy BSR.")
      .def("mass", [](PyModel& s) {
        Bcsr M = s.m().assembler().make_matrix();
        {
          py::gil_scoped_release nogil;
          s.m().assemble_mass(M);
        }
        return bsr_copy(M);
      }, "The consistent mass matrix over the free dofs; pmgkit returns it as SciPy BSR.")
      .def("gravity", [](PyModel& s, std::vector<double> g) { return to_numpy(s.m().gravity(vec3(g, "gravity"))); },
           py::arg("g"),
           "The load of gravity g (3 numbers, m/s^2) on the material's density, as a full vector.")
      .def("point_force", [](PyModel& s, std::vector<double> x, std::vector<double> F) {
        Vector f = Vector::Zero(s.m().num_dofs());
        s.m().add_point_force(f, vec3(x, "point"), vec3(F, "force"));
        return to_numpy(std::move(f));
      }, py::arg("x"), py::arg("F"),
         "The load of a force F (3 numbers, N) at the point x (3 numbers, inside the mesh), as a full vector. "
         "Raises InputError when x lies outside the mesh.")
      .def("traction", [](PyModel& s, py::function on_face, std::vector<double> t) {
        Vector f = Vector::Zero(s.m().num_dofs());
        const double area = s.m().add_traction(f, [&](const fem::Vec3& X) {
          return predicate_answer(on_face(points_array({X})[py::make_tuple(0)]), "traction: on_face");
        }, vec3(t, "traction"));
        return py::make_tuple(to_numpy(std::move(f)), area);
      }, py::arg("on_face"), py::arg("t"),
         "A uniform traction t (3 numbers, N/m^2) on every boundary face whose three vertices satisfy on_face "
         "(a function of a position returning True or False); returns (load as a full vector, area loaded).")
      .def("restrict_to_free", [](PyModel& s, const DoubleArray& u) {
        return to_numpy(s.m().restrict_to_free(to_vector(u, s.m().num_dofs(), "full vector")));
      }, py::arg("u"), "The free nodes' entries of a full vector u (num_dofs entries): a free vector.")
      .def("expand", [](PyModel& s, const DoubleArray& u) {
        return to_numpy(s.m().expand(to_vector(u, s.m().num_free_dofs(), "free vector"), Vector()));
      }, py::arg("u"), "A full vector from a free vector u (num_free_dofs entries), zero at the fixed nodes.")
      .def("free_positions", [](PyModel& s) { return to_numpy(s.m().free_positions()); },
           "Rest positions of the free nodes, x, y, z interleaved like a free vector (rigid-body modes for "
           "algebraic multigrid).")
      .def("displacement_at", [](PyModel& s, const DoubleArray& u, const DoubleArray& points) {
        if (points.ndim() != 2 || points.shape(1) != 3) throw InputError("points: expected an (n, 3) array");
        const Vector uu = to_vector(u, s.m().num_dofs(), "u (full vector)");
        py::array_t<double> out({points.shape(0), py::ssize_t(3)});
        const double* p = points.data();
        double* o = out.mutable_data();
        const fem::PointLocator& loc = s.locator();
        py::gil_scoped_release nogil;
        loc.displacements(uu, p, static_cast<index_t>(points.shape(0)), o);
        return out;
      }, py::arg("u"), py::arg("points"),
         "The displacement u (a full vector) at rest points (an (n, 3) array), as an (n, 3) array; points are "
         "found through a grid over the elements.")
      .def("solve_static", [](PyModel& s, const DoubleArray& f, bool corotational) {
        const Vector ff = to_vector(f, s.m().num_dofs(), "force (full vector)");
        fem::StaticResult r;
        {
          py::gil_scoped_release nogil;
          r = fem::solve_static(s.m(), ff, corotational);
        }
        return py::make_tuple(to_numpy(std::move(r.u)), r.iterations);
      }, py::arg("f"), py::arg("corotational") = false,
         "The static displacement under the load f (a full vector) with the default direct solver; returns "
         "(u as a full vector, iterations: 1 for linear, the fixed-point iterations when corotational). Raises "
         "InputError when no node is fixed, Error when the system is not positive definite.")
      .def("__repr__", [](PyModel& s) {
        const fem::ElasticityModel& e = s.m();
        return "<pmgkit.ElasticModel: degree " + std::to_string(e.space().degree()) + " on " +
               grouped(e.space().mesh().num_tets()) + " tetrahedra, " + grouped(e.num_nodes()) + " nodes, " +
               grouped(e.num_dofs()) + " dofs (" + grouped(3 * (e.num_nodes() - e.num_fixed())) + " free, " +
               grouped(e.num_fixed()) + " nodes fixed)>";  // counted: the assembler would freeze the fixed set
      });
}

/// Per-vertex flags of a mesh carried to its refinements: a new vertex takes the bits both ends of
/// its edge have (clamps and held components by position, as fix_vertices reads them).
std::vector<char> refine_flags(std::vector<char> flags, const std::vector<fem::Refinement>& record) {
  for (const fem::Refinement& r : record) {
    flags.resize(r.fine_vertices());
    for (size_t k = 0; k < r.midpoints.size(); ++k)
      flags[r.coarse_vertices + k] = static_cast<char>(flags[r.midpoints[k][0]] & flags[r.midpoints[k][1]]);
  }
  return flags;
}

/// DegreeHierarchy(..., refine=k): the hierarchy of mesh refined k times, its coarser meshes kept.
PyHierarchy refined_hierarchy(std::shared_ptr<const fem::TetMesh> coarse, int degree, const fem::Material& material,
                              py::object clamp, py::object components, int refine) {
  std::vector<fem::Refinement> record;
  auto fine = std::make_shared<const fem::TetMesh>(fem::refine_uniform(*coarse, refine, &record));
  // Flags for the given mesh's vertices are carried over; a function is asked on the refined mesh.
  auto given_for_coarse = [&](const py::object& o) {
    if (o.is_none() || PyCallable_Check(o.ptr())) return false;
    const py::array a = py::module_::import("numpy").attr("asarray")(o);
    return a.ndim() >= 1 && a.shape(0) == coarse->num_vertices() && coarse->num_vertices() != fine->num_vertices();
  };
  std::vector<char> mask = given_for_coarse(clamp) ? refine_flags(clamp_mask(*coarse, clamp), record)
                                                   : clamp_mask(*fine, clamp);
  std::vector<char> held;
  if (!components.is_none())
    held = given_for_coarse(components) ? refine_flags(component_masks(*coarse, components), record)
                                        : component_masks(*fine, components);
  auto h = std::make_unique<fem::DegreeHierarchy>(*fine, degree, material, std::move(mask), std::move(held));
  h->set_refinements(record);
  PyHierarchy out{fine, std::move(h)};
  py::gil_scoped_release nogil;
  out.h->assemble(nullptr);
  return out;
}

/// DegreeHierarchy: the p-multigrid levels of a model.
void register_hierarchy(py::module_& m) {
  py::class_<PyHierarchy>(m, "DegreeHierarchy",
                          "The p-multigrid levels of linear elasticity on one mesh: one model per degree 1..p "
                          "(level l holds degree l + 1), the same clamp on every degree, their matrices over the "
                          "free dofs (assembled at construction) and the degree-elevation prolongations.")
      .def(py::init([](std::shared_ptr<const fem::TetMesh> mesh, int degree, const fem::Material& material, py::object clamp,
                       py::object components, int refine) {
             if (degree < 1 || degree > 3) throw InputError("degree must be 1, 2 or 3, got " + std::to_string(degree));
             material.check();
             if (refine < 0 || refine > 4) throw InputError("refine must lie in [0, 4], got " + std::to_string(refine));
             if (refine > 0) return refined_hierarchy(mesh, degree, material, clamp, components, refine);
             const std::vector<char> mask = clamp_mask(*mesh, clamp);
             // The hierarchy asks by rest position: the clamped vertices' positions, looked up.
             std::set<std::array<double, 3>> clamped;
             for (index_t v = 0; v < mesh->num_vertices(); ++v)
               if (mask[v]) clamped.insert({mesh->vertices[v].x(), mesh->vertices[v].y(), mesh->vertices[v].z()});
             auto h = std::make_unique<fem::DegreeHierarchy>(*mesh, degree, material, [&](const fem::Vec3& X) {
               return clamped.count({X.x(), X.y(), X.z()}) > 0;
             }, component_masks(*mesh, components));
             PyHierarchy out{mesh, std::move(h)};
             py::gil_scoped_release nogil;
             out.h->assemble(nullptr);
             return out;
           }),
           py::arg("mesh"), py::arg("degree"), py::arg("material") = fem::Material{}, py::arg("clamp") = py::none(),
           py::arg("components") = py::none(), py::arg("refine") = 0,
           "Levels of degrees 1..degree (degree 1, 2 or 3) on mesh with material. clamp: the clamped vertices, "
           "one boolean per vertex or a function of a position (None: nothing clamped). components: an "
           "(n_vertices, 3) boolean array holding single components at zero (symmetry planes, rollers), or "
           "None. refine: refine the mesh uniformly this many times (0 to 4) and keep the coarser meshes under the "
           "linear level (the solvers' coarse_meshes); the hierarchy's `mesh` is then the refined one, and clamp "
           "and components may be given for either mesh's vertices (a new vertex takes what both ends of its edge "
           "have). Raises InputError for another degree, a material out of range, refine out of range or masks "
           "of the wrong shape.")
      .def_property_readonly("mesh", [](const PyHierarchy& s) { return std::const_pointer_cast<fem::TetMesh>(s.mesh); },
                             "The mesh the levels are built on (the refined one with refine > 0).")
      .def("constrained_dofs", [](const PyHierarchy& s) {
        const std::vector<char>* c = s.h->constrained_dofs(s.h->num_levels() - 1);
        py::array_t<bool> out(c ? static_cast<py::ssize_t>(c->size()) : 0);
        for (size_t i = 0; c && i < c->size(); ++i) out.mutable_data()[i] = (*c)[i] != 0;
        return out;
      }, "Per free dof of the finest level: True for a component held by `components` (empty without them).")
      .def_property_readonly("num_levels", [](const PyHierarchy& s) { return s.h->num_levels(); },
                             "Levels (degrees 1..p): p.")
      // Copied under the hierarchy's lock (the GIL released first, as the solvers take it): a solver
      // being built on another thread re-assembles the levels.
      .def("matrix", [](const PyHierarchy& s, int l) {
        std::unique_ptr<Bcsr> copy;
        {
          py::gil_scoped_release nogil;
          std::lock_guard<std::mutex> lock(*s.lock);
          const Bcsr& A = s.h->matrix(l);
          copy = std::make_unique<Bcsr>(std::make_shared<const BlockPattern>(A.pattern()), A.values());
        }
        py::capsule owner(copy.get(), [](void* p) { delete static_cast<Bcsr*>(p); });
        const Bcsr& A = *copy.release();
        return bsr_arrays(A, owner, true);
      }, py::arg("level"),
         "Level `level`'s matrix (degree level + 1, free dofs) as BSR arrays (indptr, indices, blocks, shape) "
         "owning a copy; levels() gives them all as SciPy BSR.")
      // The prolongations never change after construction: no lock.
      .def("prolongation", [](const PyHierarchy& s, int l) { return csr_copy(s.h->prolongation(l)); }, py::arg("level"),
           "The node prolongation from level - 1 to `level` (1 <= level < num_levels; fine free nodes x coarse free "
           "nodes) as CSR arrays owning a copy; prolongations() gives them all as SciPy CSR.")
      .def("free_positions", [](const PyHierarchy& s) { return to_numpy(s.h->finest().free_positions()); },
           "Rest positions of the finest level's free nodes, x, y, z interleaved like a free vector.")
      .def("restrict_to_free", [](const PyHierarchy& s, const DoubleArray& u) {
        return to_numpy(s.h->finest().restrict_to_free(to_vector(u, s.h->finest().num_dofs(), "full vector")));
      }, py::arg("u"), "The finest level's free entries of a full vector u: the b of solver() and study().")
      .def("expand", [](const PyHierarchy& s, const DoubleArray& u) {
        return to_numpy(s.h->finest().expand(to_vector(u, s.h->finest().num_free_dofs(), "free vector"), Vector()));
      }, py::arg("u"), "A full vector of the finest degree from a free vector u, zero at the fixed nodes.")
      .def("gravity", [](const PyHierarchy& s, std::vector<double> g) { return to_numpy(s.h->finest().gravity(vec3(g, "gravity"))); },
           py::arg("g"), "The load of gravity g (3 numbers, m/s^2) on the finest degree, as a full vector.")
      .def("__repr__", [](const PyHierarchy& s) {
        int levels = 0;
        index_t free = 0;
        {
          py::gil_scoped_release nogil;  // as matrix(): a solver being built on another thread holds the lock
          std::lock_guard<std::mutex> lock(*s.lock);
          levels = s.h->num_levels();
          free = s.h->finest().num_free_dofs();
        }
        return "<pmgkit.DegreeHierarchy: degrees 1-" + std::to_string(levels) + " (" + std::to_string(levels) +
               " levels) on " + grouped(s.mesh->num_tets()) + " tetrahedra, " + grouped(free) +
               " free unknowns at degree " + std::to_string(levels) + ">";
      });
}

/// MixedElasticity: the displacement-pressure saddle point of Taylor-Hood elements.
struct PyMixed {
  std::shared_ptr<const fem::TetMesh> mesh;
  std::unique_ptr<fem::MixedElasticity> m;
};

void register_mixed(py::module_& m) {
  py::class_<PyMixed>(m, "MixedElasticity",
                      "Mixed displacement-pressure elasticity on Taylor-Hood Bernstein-Bezier tetrahedra: displacement "
                      "of degree 2 or 3, continuous pressure one degree lower, nu up to 0.5 (nearly incompressible and "
                      "incompressible material without locking). Solved by mixed-gmres (GMRES with the block-triangular "
                      "preconditioner: the p-multigrid on the nu-independent displacement block), mixed-minres, or mumps "
                      "on the assembled saddle point.")
      .def(py::init([](std::shared_ptr<const fem::TetMesh> mesh, int degree, const fem::Material& material,
                       py::object poisson, py::object clamp, py::object components) {
             fem::Material mat = material;
             if (!poisson.is_none()) mat.poisson = poisson.cast<double>();
             auto mixed = std::make_unique<fem::MixedElasticity>(*mesh, degree, mat, clamp_mask(*mesh, clamp),
                                                                 component_masks(*mesh, components));
             return PyMixed{mesh, std::move(mixed)};
           }),
           py::arg("mesh"), py::arg("degree"), py::arg("material") = fem::Material{}, py::arg("poisson") = py::none(),
           py::arg("clamp") = py::none(), py::arg("components") = py::none(),
           "The mixed system on mesh (degree 2 or 3) with material; poisson overrides the material's Poisson's ratio "
           "and may be 0.5, which Material refuses. clamp and components as for DegreeHierarchy. Raises InputError "
           "for another degree or a material out of range.")
      .def_property_readonly("num_displacement", [](const PyMixed& s) { return s.m->num_displacement(); },
                             "Displacement unknowns (3 per free node).")
      .def_property_readonly("num_pressure", [](const PyMixed& s) { return s.m->num_pressure(); },
                             "Pressure unknowns (one per node of degree - 1).")
      .def("gravity", [](const PyMixed& s, std::vector<double> g) {
        return to_numpy(s.m->hierarchy().finest().gravity(vec3(g, "gravity")));
      }, py::arg("g"), "The load of gravity g (3 numbers, m/s^2) as a full displacement vector.")
      .def("set_weights", [](PyMixed& s, double mass, double stiffness) { s.m->set_weights({mass, stiffness}); },
           py::arg("mass"), py::arg("stiffness"),
           "The system of an implicit-Euler step: displacement block mass M + stiffness A (static: 0, 1).")
      .def("restrict_to_free", [](const PyMixed& s, const DoubleArray& u) {
        return to_numpy(s.m->hierarchy().finest().restrict_to_free(
            to_vector(u, s.m->hierarchy().finest().num_dofs(), "full vector")));
      }, py::arg("u"), "The free displacement entries of a full vector u: the first part of the system's unknowns.")
      .def("rhs", [](const PyMixed& s, const DoubleArray& f) {
        return to_numpy(s.m->rhs(to_vector(f, s.m->hierarchy().finest().num_dofs(), "force (full vector)")));
      }, py::arg("f"), "The right-hand side (displacement, then zeros for the pressure) of a full load f.")
      .def("system", [](PyMixed& s) {
        Csr K;
        {
          py::gil_scoped_release nogil;
          K = s.m->assembled_system();
        }
        return csr_copy(K);
      }, "The saddle point [A B^T; B -C/s] assembled as CSR arrays (displacement first; the pressure unknowns are "
         "s p), for SciPy or a direct solver.")
      .def("solve", [](PyMixed& s, const DoubleArray& f, py::dict config, bool corotational) {
        const Vector ff = to_vector(f, s.m->hierarchy().finest().num_dofs(), "force (full vector)");
        const std::string json = py::module_::import("json").attr("dumps")(config).cast<std::string>();
        const Config c = Config::from_json(json, "MixedElasticity.solve");
        fem::MixedResult r;
        {
          py::gil_scoped_release nogil;
          r = fem::solve_mixed_static(*s.m, ff, c, nullptr, corotational);
        }
        py::dict info;
        info["status"] = to_string(r.solve.status);
        info["iterations"] = r.solve.iterations;
        info["true_rel_residual"] = r.solve.true_rel_residual;
        info["fixed_point_iterations"] = r.fixed_point_iterations;
        info["solver_iterations"] = r.solver_iterations;
        info["setup_seconds"] = r.setup_seconds;
        info["solve_seconds"] = r.solve_seconds;
        info["description"] = r.description;
        return py::make_tuple(to_numpy(std::move(r.u)), to_numpy(std::move(r.p)), info);
      }, py::arg("f"), py::arg("config") = py::dict(), py::arg("corotational") = false,
         "Solves for the full load f with the solver config (a dict: method mixed-gmres by default, mixed-minres or mumps; "
         "tol, max_iterations and the cycle's keys). corotational=True: the fixed point on the rotations "
         "(static weights, mixed-gmres or mixed-minres only; info['fixed_point_iterations'] says how many). Returns (u as a "
         "full vector, p per pressure node, info). Raises SolveError when the solve fails.")
      .def("__repr__", [](const PyMixed& s) {
        return "<pmgkit.MixedElasticity: degree " + std::to_string(s.m->hierarchy().num_levels()) + "/" +
               std::to_string(s.m->hierarchy().num_levels() - 1) + " on " + grouped(s.mesh->num_tets()) +
               " tetrahedra, " + grouped(s.m->num_displacement()) + " displacement + " +
               grouped(s.m->num_pressure()) + " pressure unknowns>";
      });
}

/// simulate(): a scene run from Python.
void register_simulation(py::module_& m) {
  // ---- simulation ----
  m.def("simulate", [](const std::string& scene_json, const std::string& origin, const std::string& output_dir,
                       bool distributed_mesh) {
    const sim::Scene scene = sim::parse_scene(scene_json, origin);
    FilePlan plan;  // the output folder may hold no input of the run
    sim::plan_files(scene, origin, output_dir, plan);
    plan.check();
    py::dict out;
    sim::RunSummary r;
    std::string method, settings;
    std::vector<std::string> notes;
    {
      py::gil_scoped_release nogil;
      sim::SceneSetup setup = distributed_mesh ? sim::set_up_on_ranks(scene) : sim::set_up(scene);
      sim::DynamicRun run(scene, setup, output_dir);
      method = run.method();
      settings = run.solver_settings();
      r = run.run();
      notes = setup.notes;
    }
    out["records"] = run_records(r);
    out["steps_done"] = r.steps_done;
    out["wall_seconds"] = r.wall_s;
    out["iterations"] = r.iterations;
    out["max_residual"] = r.max_residual;
    out["method"] = method;
    out["solver_settings"] = settings;
    out["outputs"] = r.outputs;
    out["notes"] = notes;
    out["failed_step"] = r.failed_step;
    out["failure"] = r.failure;
    out["warnings"] = r.warnings;
    return out;
  }, py::arg("scene_json"), py::arg("origin"), py::arg("output_dir") = "", py::arg("distributed_mesh") = false,
     "Runs a dynamic scene (scene_json: the scene file's JSON text; origin: its path or a name, for messages "
     "and relative paths) and returns its summary: records (per-step NumPy arrays), steps_done, wall_seconds, "
     "iterations, max_residual, method, solver_settings, outputs, notes, failed_step, failure, warnings. "
     "output_dir: also write steps.csv and the .vtu frames there. distributed_mesh: build the scene on the "
     "world's ranks, none holding the whole mesh (sim::set_up_on_ranks), and step it with petsc-mgpcg. "
     "pmgkit.simulate raises SolveError for a failed step.");
}

}  // namespace

void register_fem(py::module_& m) {
  register_mesh(m);
  register_model(m);
  register_hierarchy(m);
  register_mixed(m);
  register_simulation(m);
}

}  // namespace pmg::python
