// pmgkit.solve_distributed: a static scene built on the MPI ranks from the start (DMPlex, no rank
// holding the whole model; pmg/distributed/mesh_problem.hpp), solved by petsc-mgpcg's PETSc
// solver. Where the build has no PETSc the function says so.
#include "common.hpp"

#include "pmg/sim/scene.hpp"
#include "pmg/sparse/config.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/params.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#ifdef PMG_PY_HAVE_DISTRIBUTED
#include "pmg/distributed/scene.hpp"
#include "pmg/mpi/session.hpp"
#endif

namespace pmg::python {

#ifdef PMG_PY_HAVE_DISTRIBUTED
void register_distributed(py::module_& m) {
  m.def("solve_distributed", [](const std::string& scene_json, const std::string& origin, long handle,
                                const std::string& solver_json, const std::string& save_mesh) {
    mpi::start();
    MPI_Comm comm = handle >= 0 ? MPI_Comm_f2c(static_cast<MPI_Fint>(handle)) : MPI_COMM_WORLD;
    if (comm == MPI_COMM_NULL) throw InputError("solve_distributed: comm is MPI_COMM_NULL");
    const sim::Scene scene = sim::parse_scene(scene_json, origin);
    dist::MeshProblemOptions o = dist::mesh_problem_options(scene);
    o.save_mesh = save_mesh;
    Config c = Config::from_json(solver_json, "solve_distributed: solver");
    const std::string method = c.get_string("method", "petsc-mgpcg");
    if (method != "petsc-mgpcg")
      throw InputError("solve_distributed: solver method " + method + ": a distributed mesh is solved by petsc-mgpcg");
    dist::DistributedMgpcgParams params = read_params<dist::DistributedMgpcgParams>(c);
    params.allow_unused_options = unused_options_allowed(c);
    check_keys_used(c);
    params.throw_on_failure = false;  // the report says how the solve ended
    py::dict out;
    Vector x;
    dist::RankSolveReport r;
    std::unique_ptr<dist::MeshProblem> problem;
    {
      py::gil_scoped_release nogil;
      problem = dist::mesh_problem(comm, scene, o);
      r = dist::solve_on_ranks(*problem, params, x);
    }
    out["status"] = to_string(r.result.status);
    out["iterations"] = r.result.iterations;
    out["true_relative_residual"] = r.true_residual;
    out["compliance"] = r.compliance;
    out["max_displacement"] = r.max_displacement;
    out["unknowns"] = r.unknowns;
    out["tets"] = problem->global_cells();
    out["setup_seconds"] = r.setup_seconds;
    out["solve_seconds"] = r.solve_seconds;
    out["description"] = r.description;
    py::list stages;
    for (const auto& [name, s] : problem->stages()) stages.append(py::make_tuple(name, s));
    out["stages"] = stages;
    std::vector<double> history;
    for (const auto& h : r.history) history.push_back(h.rel_residual);
    out["history"] = py::array_t<double>(static_cast<py::ssize_t>(history.size()), history.data());
    out["owned_displacement"] = py::array_t<double>(static_cast<py::ssize_t>(x.size()), x.data());
    return out;
  }, py::arg("scene_json"), py::arg("origin"), py::arg("communicator"), py::arg("solver_json"), py::arg("save_mesh"),
     "The core of pmgkit.solve_distributed: a static scene (JSON text, its origin for messages) built on the "
     "ranks of a communicator (Fortran handle, -1: MPI_COMM_WORLD) and solved by petsc-mgpcg (the solver's JSON "
     "keys); save_mesh: also write the refined mesh there (.h5). Returns the report as a dict.");
}

#else

void register_distributed(py::module_& m) {
  m.def("solve_distributed", [](const std::string&, const std::string&, long, const std::string&, const std::string&) {
    throw InputError("solve_distributed: this build has no PETSc (pmg::distributed is not built)");
    return py::dict();
  }, "The core of pmgkit.solve_distributed; this build has no PETSc, so it raises InputError.");
}

#endif

}  // namespace pmg::python
