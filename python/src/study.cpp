// pmgkit.study and pmgkit.study_scene: pmg::study (the layer pmg compare runs on) from Python.
#include "common.hpp"

#include "pmg/mpi/session.hpp"
#include "pmg/sim/scene.hpp"
#include "pmg/sim/system.hpp"
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/defaults.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/layout.hpp"
#include "pmg/study/study.hpp"

#include <nlohmann/json.hpp>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace pmg::python {

namespace {

/// pmgkit.study's core: the solvers of `solvers_json` (an object of named configurations, in
/// order) on one system through pmg::study, as pmg compare runs them; one dict per run.
py::list study_runs(study::StudySystem& ss, const std::string& solvers_json, bool warm_up,
                    const std::function<void(study::Study&)>& before_run, const char* fallback) {
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(solvers_json);
  if (!j.is_object() || j.empty()) throw InputError("study: solvers: expected named solver configurations");
  study::Study st(ss);
  for (auto it = j.begin(); it != j.end(); ++it)
    st.add(it.key(), Config::from_json(it.value().dump(), "study: " + it.key()), {}, fallback);
  before_run(st);
  std::vector<study::SolverRun> runs;
  {
    py::gil_scoped_release nogil;
    runs = st.run(warm_up);
  }
  auto maybe = [](double v) { return std::isfinite(v) ? py::object(py::float_(v)) : py::object(py::none()); };
  py::list out;
  for (const study::SolverRun& r : runs) {
    py::dict d;
    d["name"] = r.name, d["config"] = r.config, d["status"] = r.status, d["message"] = r.message;
    d["iterations"] = r.iterations, d["setup_seconds"] = r.setup_s, d["solve_seconds"] = r.solve_s;
    d["time_to_1e-3"] = maybe(r.time_to(1e-3)), d["time_to_1e-6"] = maybe(r.time_to(1e-6));
    d["rel_residual"] = maybe(r.rel_residual), d["rel_error"] = maybe(r.rel_error), d["b_dot_x"] = maybe(r.b_dot_x);
    d["settings"] = r.settings, d["breakdown"] = r.breakdown, d["setup_breakdown"] = r.setup_breakdown;
    Vector rel(static_cast<Eigen::Index>(r.history.size())), sec(rel.size());
    for (size_t k = 0; k < r.history.size(); ++k) rel[k] = r.history[k].rel_residual, sec[k] = r.history[k].seconds;
    d["history"] = to_numpy(std::move(rel));
    d["history_seconds"] = to_numpy(std::move(sec));
    out.append(d);
  }
  return out;
}

}  // namespace

/// study_matrix (a user's matrix), study_hierarchy (an FEM degree hierarchy) and study_scene (a
/// scene's linear system).
void register_study(py::module_& m) {
  m.def("study_matrix", [](py::tuple A, const DoubleArray& b, const std::string& solvers, std::optional<DoubleArray> reference,
                           std::optional<DoubleArray> coordinates, const std::string& format, bool warm_up) {
    const ArrayCsr a = array_csr(A, "matrix");
    check_format_name(format);
    const Csr csr = symmetric_csr(a.view);
    const std::string f = matrix_format(format, csr);  // auto: blocks where the matrix reads as blocks
    std::unique_ptr<Bcsr> bcsr = f != "csr" ? std::make_unique<Bcsr>(Bcsr::from_csr(csr)) : nullptr;
    std::unique_ptr<BinBcsr> bin = f == "bin-bcsr" ? std::make_unique<BinBcsr>(*bcsr) : nullptr;
    study::StudySystem ss;
    ss.repeat_short_runs = mpi::launched_ranks() <= 1;  // under mpirun every rank runs each solver alike
    ss.description = "matrix " + std::to_string(csr.rows()) + "x" + std::to_string(csr.cols());
    ss.matrix = bcsr ? static_cast<const LinearOperator*>(bcsr.get()) : &csr;
    ss.product = bin ? static_cast<const LinearOperator*>(bin.get()) : nullptr;
    ss.b = to_vector(b, csr.rows(), "b");
    if (reference) ss.reference = to_vector(*reference, csr.rows(), "reference");
    std::vector<double> xyz;
    if (coordinates) {
      const Vector c = to_vector(*coordinates, csr.rows(), "coordinates");
      xyz.assign(c.data(), c.data() + c.size());
      ss.coordinates = &xyz;
    }
    return study_runs(ss, solvers, warm_up, [](study::Study&) {}, kDefaultMethod);
  }, py::arg("A"), py::arg("b"), py::arg("solvers"), py::arg("reference") = py::none(),
     py::arg("coordinates") = py::none(), py::arg("format") = "auto", py::arg("warm_up") = false,
     "The core of pmgkit.study on a matrix: A as CSR arrays (indptr, indices, data, shape), b, solvers as a "
     "JSON object of named configurations (in order), reference (the solution errors are measured against, "
     "or None), coordinates (x, y, z per node, or None), format (auto | csr | bcsr | bin-bcsr: the format "
     "the Krylov methods multiply in; auto: 3x3 blocks when the matrix reads as blocks), warm_up. Returns "
     "one dict per solver. Raises InputError for a bad matrix or config, or a block method on a matrix that "
     "does not read as 3x3 blocks.");
  m.def("study_hierarchy", [](PyHierarchy& h, const DoubleArray& b, const std::string& solvers,
                              std::optional<DoubleArray> reference, bool warm_up) {
    std::unique_lock<std::mutex> lock;  // its solvers share the hierarchy's operators
    {
      py::gil_scoped_release nogil;  // never wait for the lock holding the GIL
      lock = std::unique_lock<std::mutex>(*h.lock);
    }
    fem::DegreeHierarchy& H = *h.h;
    const int L = H.num_levels();
    const index_t n = H.finest().num_free_dofs();
    study::StudySystem ss;
    ss.repeat_short_runs = mpi::launched_ranks() <= 1;  // under mpirun every rank runs each solver alike
    ss.description = "degree " + std::to_string(L) + " hierarchy, " + std::to_string(n) + " free unknowns";
    ss.b = to_vector(b, n, "b");
    if (reference) ss.reference = to_vector(*reference, n, "reference");
    ss.levels = &H;
    ss.hierarchy = &H;
    const std::vector<double> xyz = H.node_coordinates(L - 1);
    ss.coordinates = &xyz;
    return study_runs(ss, solvers, warm_up, [&](study::Study& st) {
      if (!st.reads_finest_matrix()) return;
      H.assemble_level(L - 1, nullptr);  // the finest matrix some solver reads (R = I, static weights)
      ss.matrix = &H.matrix(L - 1);
    }, kDefaultLevelsMethod);
  }, py::arg("hierarchy"), py::arg("b"), py::arg("solvers"), py::arg("reference") = py::none(),
     py::arg("warm_up") = false,
     "The core of pmgkit.study on a DegreeHierarchy: b over its finest free unknowns, solvers as a JSON object "
     "of named configurations (default method mgpcg), reference or None, warm_up. Returns one dict per "
     "solver.");
  m.def("study_scene", [](const std::string& scene_json, const std::string& origin, const std::string& solvers,
                          double dt, bool direct_reference, bool warm_up) {
    std::unique_ptr<sim::SceneSystem> sys;
    {
      py::gil_scoped_release nogil;
      const sim::Scene scene = sim::parse_scene(scene_json, origin);
      sys = std::make_unique<sim::SceneSystem>(sim::system_of(scene, dt, /*assemble_finest=*/direct_reference));
    }
    study::StudySystem ss;
    ss.repeat_short_runs = mpi::launched_ranks() <= 1;  // under mpirun every rank runs each solver alike
    ss.description = origin;
    ss.b = sys->b;
    ss.levels = &sys->hierarchy();
    ss.hierarchy = &sys->hierarchy();
    ss.weights = sys->weights();
    const std::vector<double> xyz = sys->free_coordinates();
    ss.coordinates = &xyz;
    if (direct_reference) {  // the errors against a direct solve of the assembled system
      py::gil_scoped_release nogil;
      auto direct = make_solver(Config::from_pairs({std::string("method=") + kDefaultDirectMethod}, "the reference solve"));
      direct->setup(sys->matrix());
      direct->apply(sys->b, ss.reference);
      ss.matrix = &sys->matrix();
    }
    return study_runs(ss, solvers, warm_up, [&](study::Study& st) {
      if (!st.reads_finest_matrix() || ss.matrix) return;
      sys->assemble_finest();
      ss.matrix = &sys->matrix();
    }, kDefaultLevelsMethod);
  }, py::arg("scene"), py::arg("origin"), py::arg("solvers"), py::arg("dt") = 0.0, py::arg("direct_reference") = true,
     py::arg("warm_up") = false,
     "The core of pmgkit.study_scene: scene as the scene file's JSON text, origin (its path or a name), "
     "solvers as a JSON object of named configurations, dt (0: the static system; > 0: one implicit-Euler "
     "step's), direct_reference (errors against a direct solve), warm_up. Returns one dict per solver.");
}

}  // namespace pmg::python
