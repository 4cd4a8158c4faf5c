// pmgkit._core — the compiled half of the Python module. Every solver is built by the one factory
// (pmg::make_solver), every multigrid hierarchy from the user's levels by mg::UserLevels or from
// the BB degree hierarchy: this file converts arrays and errors, nothing more. The SciPy side
// (sparse formats, LinearOperator, dict configs) is pmgkit/__init__.py.
//
// Arrays: matrices arrive as CSR arrays (indptr, indices: int32 or int64; data: float64) read in
// place through a CsrView; results leave as NumPy arrays that own pmgkit's buffers (no copy).
// Right-hand sides are copied once into pmgkit's vector type (O(n), next to a solve's O(nnz·its)).
// The GIL is released during set-up, updates, solves, products, assembly and simulation: the
// caller must not modify the arrays it passed while such a call runs in another thread.
#include "pmg/fem/elasticity.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/locator.hpp"
#include "pmg/fem/mesh.hpp"
#include "pmg/fem/mesh_io.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/solvers.hpp"
#include "pmg/multigrid/user_levels.hpp"
#include "pmg/sim/run.hpp"
#include "pmg/sim/scene.hpp"
#include "pmg/sim/setup.hpp"
#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/csr_view.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/petsc_binary.hpp"
#include "pmg/sparse/timer.hpp"

#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <set>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace py = pybind11;
using namespace pmg;

namespace {


// ---- arrays ------------------------------------------------------------------------------------

/// A CSR matrix handed over as (indptr, indices, data, (rows, cols)): the arrays are read in place.
/// The Python objects are held so that the view stays valid as long as this lives.
struct ArrayCsr {
  py::array indptr, indices, data;
  CsrView view;
};

int index_bytes(const py::array& a, const std::string& who) {
  if (a.ndim() != 1 || !(a.flags() & py::array::c_style))
    throw InputError(who + ": expected a contiguous one-dimensional integer array");
  const auto k = a.dtype().kind();
  if ((k == 'i' || k == 'u') && (a.itemsize() == 4 || a.itemsize() == 8) && !(k == 'u' && a.itemsize() == 8))
    return static_cast<int>(a.itemsize());
  throw InputError(who + ": indices must be int32 or int64, got " + std::string(py::str(a.dtype())));
}

ArrayCsr array_csr(py::tuple m, const std::string& who) {
  if (m.size() != 4) throw InputError(who + ": expected (indptr, indices, data, shape)");
  ArrayCsr a{m[0].cast<py::array>(), m[1].cast<py::array>(), m[2].cast<py::array>(), {}};
  const auto shape = m[3].cast<std::pair<long long, long long>>();
  if (shape.first < 0 || shape.second < 0 || shape.first > 2147483647LL || shape.second > 2147483647LL)
    throw InputError(who + ": shape out of range (at most 2^31 - 1 rows and columns)");
  if (!py::isinstance<py::array_t<double>>(a.data) || a.data.ndim() != 1 || !(a.data.flags() & py::array::c_style))
    throw InputError(who + ": values must be a contiguous float64 array");
  a.view.rows = static_cast<index_t>(shape.first);
  a.view.cols = static_cast<index_t>(shape.second);
  a.view.row_ptr_bytes = index_bytes(a.indptr, who + " indptr");
  a.view.col_idx_bytes = index_bytes(a.indices, who + " indices");
  if (a.indptr.shape(0) != a.view.rows + 1)
    throw InputError(who + ": indptr has " + std::to_string(a.indptr.shape(0)) + " entries, " +
                     std::to_string(a.view.rows + 1) + " expected");
  if (a.indices.shape(0) != a.data.shape(0))
    throw InputError(who + ": indices and data differ in length");
  a.view.nnz = static_cast<offset_t>(a.data.shape(0));
  a.view.row_ptr = a.indptr.data();
  a.view.col_idx = a.indices.data();
  a.view.values = static_cast<const double*>(a.data.data());
  a.view.validate(who, false);  // rows in any order: to_csr and UserLevels sort or walk them
  return a;
}

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

Vector to_vector(const DoubleArray& a, Eigen::Index n, const std::string& who) {
  if (a.ndim() != 1 || a.shape(0) != n)
    throw InputError(who + " has shape " + std::string(py::str(a.attr("shape"))) + ", expected (" +
                     std::to_string(n) + ",)");
  return Eigen::Map<const Vector>(a.data(), n);
}

/// A NumPy array owning `v`'s buffer (moved, not copied).
py::array_t<double> to_numpy(Vector&& v) {
  auto* owner = new Vector(std::move(v));
  py::capsule free_it(owner, [](void* p) { delete static_cast<Vector*>(p); });
  return py::array_t<double>({owner->size()}, {sizeof(double)}, owner->data(), free_it);
}

/// A NumPy array viewing a std::vector held by `base` (no copy; base is kept alive by the array).
template <typename T>
py::array_t<T> view_vector(const std::vector<T>& v, py::handle base) {
  return py::array_t<T>({static_cast<py::ssize_t>(v.size())}, {sizeof(T)}, v.data(), base);
}

// ---- solvers -------------------------------------------------------------------------------------

/// One solver from the factory on a user's matrix (or user levels), owning its operator.
/// A degree hierarchy with the mesh it refers to; its solvers take `lock` while they build or
/// solve (they share its operators).
struct PyHierarchy {
  std::shared_ptr<const fem::TetMesh> mesh;
  std::unique_ptr<fem::DegreeHierarchy> h;
  std::shared_ptr<std::mutex> lock = std::make_shared<std::mutex>();
};

class PySolver {
 public:
  /// A single matrix; format auto (BCSR when the size is a multiple of 3) | csr | bcsr | bin-bcsr.
  PySolver(py::tuple A, const std::string& config_json, const std::string& format,
           std::optional<DoubleArray> coordinates)
      : config_(Config::from_json(config_json, "config")) {
    ArrayCsr a = array_csr(A, "matrix");
    if (a.view.rows != a.view.cols) throw InputError("matrix: must be square, is " + std::to_string(a.view.rows) + "x" + std::to_string(a.view.cols));
    method_ = config_.get_string("method", "cg");
    std::string f = format;
    if (f == "auto") f = a.view.rows % 3 == 0 ? "bcsr" : "csr";
    if (f != "csr" && f != "bcsr" && f != "bin-bcsr") throw InputError("format: expected auto, csr, bcsr or bin-bcsr, got '" + format + "'");
    if (method_needs_blocks(method_) && a.view.rows % 3 != 0)
      throw InputError("method " + method_ + " reads 3x3 blocks, and the matrix's size " + std::to_string(a.view.rows) +
                       " is not divisible by 3: choose a method for scalar matrices (cg, jacobi-pcg, cholmod, "
                       "pmgkit.methods() lists each one's needs)");
    if (method_needs_blocks(method_) && f == "csr")
      throw InputError("method " + method_ + " reads 3x3 blocks: use format='bcsr' or 'auto'");
    {
      py::gil_scoped_release nogil;
      csr_ = to_csr(a.view, "matrix");
      if (!csr_.is_symmetric(1e-12)) throw InputError("matrix: not symmetric (the solvers need a symmetric positive definite matrix)");
      if (f != "csr") bcsr_ = std::make_unique<Bcsr>(Bcsr::from_csr(csr_));
      if (f == "bin-bcsr") bin_ = std::make_unique<BinBcsr>(*bcsr_);
    }
    op_ = bin_ ? static_cast<const LinearOperator*>(bin_.get())
               : bcsr_ ? static_cast<const LinearOperator*>(bcsr_.get()) : &csr_;
    if (coordinates) {
      const Vector c = to_vector(*coordinates, csr_.rows(), "coordinates");
      coordinates_.assign(c.data(), c.data() + c.size());
      context_.coordinates = &coordinates_;
    }
    build();
  }

  /// User multigrid levels (coarsest first; just the finest with galerkin_only).
  PySolver(py::list matrices, py::list prolongations, const std::string& config_json,
           const std::string& layout, bool galerkin_only)
      : config_(Config::from_json(config_json, "config")) {
    std::vector<ArrayCsr> mats, ps;
    for (size_t l = 0; l < matrices.size(); ++l)
      mats.push_back(array_csr(matrices[l].cast<py::tuple>(), galerkin_only ? "finest matrix" : "level matrix " + std::to_string(l)));
    for (size_t l = 0; l < prolongations.size(); ++l)
      ps.push_back(array_csr(prolongations[l].cast<py::tuple>(), "prolongation " + std::to_string(l + 1)));
    mg::UserLevelOptions o;
    o.layout = mg::parse_layout(layout);
    o.galerkin_only = galerkin_only;
    method_ = config_.get_string("method", "mgpcg");
    config_.set_default("method", method_);
    if (galerkin_only && method_accepts_key(method_, "coarse_operator")) config_.set_default("coarse_operator", "galerkin");
    {
      py::gil_scoped_release nogil;
      levels_ = std::make_unique<mg::UserLevels>(views(mats), views(ps), o);
    }
    op_ = &levels_->matrix(levels_->num_levels() - 1);
    context_.levels = levels_.get();
    build();
  }

  /// A factory method on an FEM degree hierarchy (its finest level's free unknowns), as in
  /// `pmg compare`: multigrid methods take the hierarchy's levels (matrix-free where they ask
  /// for it); petsc-mgpcg runs across the ranks of `communicator` (a Fortran handle, -1: world).
  PySolver(PyHierarchy& h, const std::string& config_json, long communicator)
      : config_(Config::from_json(config_json, "config")) {
    method_ = config_.get_string("method", "mgpcg");
    config_.set_default("method", method_);
    hierarchy_ = h.h.get();
    hierarchy_lock_ = h.lock;
    context_.levels = hierarchy_;
    context_.communicator = communicator;
    coordinates_ = hierarchy_->node_coordinates(hierarchy_->num_levels() - 1);
    context_.coordinates = &coordinates_;
    build();
  }

  py::tuple solve(const DoubleArray& b_in, std::optional<DoubleArray> x0_in, std::optional<double> tol) {
    const Eigen::Index n = full_size();
    const Vector b_full = to_vector(b_in, n, "b");
    Vector x = x0_in ? to_vector(*x0_in, n, "x0") : Vector::Zero(n);
    SolveMonitor monitor;
    SolveResult r;
    double seconds = 0, true_res = 0, setup_seconds = 0;
    std::string method;
    Vector x_full;
    {
      py::gil_scoped_release nogil;
      std::lock_guard<std::mutex> lock(mutex_);  // after the GIL is released: no lock-order cycle
      const auto shared = lock_hierarchy();
      if (tol && (!config_.has("tol") || config_.get_double("tol", 0, 0, 1) != *tol)) {
        char text[32];
        std::snprintf(text, sizeof text, "%.17g", *tol);
        Config with_tol = config_.clone();
        with_tol.set("tol", text);  // a new stopping rule: a new solver, kept only if it sets up
        build_locked(with_tol);
        config_ = std::move(with_tol);
      }
      const Vector b = levels_ ? levels_->reduce(b_full) : b_full;
      if (levels_) x = levels_->reduce(x);
      const auto t0 = Clock::now();
      r = solver_->solve(b, x, &monitor);
      seconds = seconds_since(t0);
      Vector res(b.size());
      op_->residual(b, x, res);
      const double bn = b_full.norm();
      true_res = bn > 0 ? res.norm() / bn : res.norm();
      x_full = levels_ ? levels_->expand(x, b_full) : std::move(x);
      setup_seconds = setup_seconds_;
      method = solver_->name();
    }
    const auto& h = monitor.history();
    std::vector<double> hr, ht;
    for (const auto& rec : h) hr.push_back(rec.rel_residual), ht.push_back(rec.seconds);
    py::dict info;
    info["status"] = to_string(r.status);
    info["iterations"] = r.iterations;
    info["residual"] = true_res;
    info["rel_residual"] = r.true_rel_residual;
    info["history"] = py::array_t<double>(hr.size(), hr.data());
    info["history_seconds"] = py::array_t<double>(ht.size(), ht.data());
    info["setup_seconds"] = setup_seconds;
    info["solve_seconds"] = seconds;
    info["method"] = method;
    info["message"] = r.message;
    return py::make_tuple(to_numpy(std::move(x_full)), info);
  }

  /// x = M b: the solver as a preconditioner.
  py::array_t<double> apply(const DoubleArray& b_in) {
    const Vector b_full = to_vector(b_in, full_size(), "b");
    Vector x;
    {
      py::gil_scoped_release nogil;
      std::lock_guard<std::mutex> lock(mutex_);
      const auto shared = lock_hierarchy();
      const Vector b = levels_ ? levels_->reduce(b_full) : b_full;
      Vector y(b.size());
      solver_->apply(b, y);
      x = levels_ ? levels_->expand(y, b_full) : std::move(y);
    }
    return to_numpy(std::move(x));
  }

  void update(py::tuple A) {
    if (levels_) throw InputError("update: these are multigrid levels: pass the list of level matrices");
    if (hierarchy_) throw InputError("update: this solver is built on a DegreeHierarchy, which has no matrix to replace; build a new solver");
    ArrayCsr a = array_csr(A, "matrix");
    if (!view_of(csr_).same_pattern(a.view))
      throw InputError("update: the new matrix must have the pattern of the one the solver was set up "
                       "on (same indptr and indices); build a new solver for a new pattern");
    py::gil_scoped_release nogil;
    std::lock_guard<std::mutex> lock(mutex_);
    const auto t0 = Clock::now();
    std::vector<double> previous(csr_.values().begin(), csr_.values().end());
    std::copy(a.view.values, a.view.values + a.view.nnz, csr_.values().begin());
    if (!csr_.is_symmetric(1e-12)) {
      std::copy(previous.begin(), previous.end(), csr_.values().begin());  // the solver's matrix unchanged
      throw InputError("update: the new matrix is not symmetric");
    }
    if (bcsr_) bcsr_->set_values(csr_);
    if (bin_) bin_->update_values(*bcsr_);
    solver_->update();
    setup_seconds_ = seconds_since(t0);
  }

  void update_levels(py::list matrices) {
    if (!levels_) throw InputError("update_levels: this solver was not built on multigrid levels");
    std::vector<ArrayCsr> mats;
    for (size_t l = 0; l < matrices.size(); ++l)
      mats.push_back(array_csr(matrices[l].cast<py::tuple>(), "level matrix " + std::to_string(l)));
    py::gil_scoped_release nogil;
    std::lock_guard<std::mutex> lock(mutex_);
    const auto t0 = Clock::now();
    levels_->set_values(views(mats));
    solver_->update();
    setup_seconds_ = seconds_since(t0);
  }

  Eigen::Index full_size() const { return levels_ ? levels_->full_size() : op_->rows(); }
  // These take the lock with the GIL held: no locked region ever waits for the GIL.
  std::string name() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return solver_->name();
  }
  std::string describe() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return solver_->describe();
  }
  double setup_seconds() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return setup_seconds_;
  }
  /// f(levels) with mutex_ held, so that an update_levels() on another thread is not seen half
  /// done (the GIL is held too: no locked region ever waits for it). InputError naming `what`
  /// for a solver without user levels.
  template <typename F>
  auto with_levels(const char* what, F f) const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!levels_) throw InputError(std::string(what) + ": not a multigrid solver on user levels");
    return f(*levels_);
  }
  bool has_levels() const { return levels_ != nullptr; }

 private:
  static std::vector<CsrView> views(const std::vector<ArrayCsr>& a) {
    std::vector<CsrView> v;
    for (const auto& x : a) v.push_back(x.view);
    return v;
  }
  /// At construction (no other thread can hold the object yet).
  void build() {
    py::gil_scoped_release nogil;
    const auto shared = lock_hierarchy();
    build_locked(config_);
  }
  /// A new solver from `config`, set up on op_, replacing solver_ only when its set-up succeeded;
  /// the GIL released and mutex_ and the hierarchy's lock held (or constructing).
  void build_locked(const Config& config) {
    auto solver = make_solver(config, context_, levels_ || hierarchy_ ? "mgpcg" : "cg");
    start_libraries(config);  // MPI and PETSc where the method needs them, outside its set-up time
    if (hierarchy_) op_ = &hierarchy_->prepare(solver->needs(), nullptr);
    const auto t0 = Clock::now();
    solver->setup(*op_);
    setup_seconds_ = seconds_since(t0);
    solver_ = std::move(solver);
  }

  /// The hierarchy's lock, held (after mutex_) while this solver builds, solves or applies.
  std::unique_lock<std::mutex> lock_hierarchy() const {
    return hierarchy_lock_ ? std::unique_lock<std::mutex>(*hierarchy_lock_) : std::unique_lock<std::mutex>();
  }

  Config config_;
  std::string method_;
  fem::DegreeHierarchy* hierarchy_ = nullptr;
  std::shared_ptr<std::mutex> hierarchy_lock_;
  Csr csr_;
  std::unique_ptr<Bcsr> bcsr_;
  std::unique_ptr<BinBcsr> bin_;
  std::unique_ptr<mg::UserLevels> levels_;
  std::vector<double> coordinates_;
  SolverContext context_;
  const LinearOperator* op_ = nullptr;
  std::unique_ptr<Solver> solver_;
  double setup_seconds_ = 0.0;
  /// Serialises the calls on this object from several Python threads (solve's rebuild for a new
  /// tol, update's new values and the solve itself must not interleave).
  mutable std::mutex mutex_;
};

// ---- formats -------------------------------------------------------------------------------------

/// y = A x into NumPy arrays, without copies (x converted only if not contiguous float64).
template <typename Op>
py::array_t<double> matvec(const Op& A, const DoubleArray& x, std::optional<py::array_t<double>> out) {
  if (x.ndim() != 1 || x.shape(0) != A.cols())
    throw InputError("x has " + std::to_string(x.size()) + " entries, the matrix " + std::to_string(A.cols()) + " columns");
  py::array_t<double> y = out ? *out : py::array_t<double>(A.rows());
  if (y.ndim() != 1 || y.shape(0) != A.rows() || !(y.flags() & py::array::c_style) || !y.writeable())
    throw InputError("out must be a writable contiguous float64 array of " + std::to_string(A.rows()) + " entries");
  double* yp = y.mutable_data();
  const double* xp = x.data();
  {
    py::gil_scoped_release nogil;
    A.multiply(xp, yp);
  }
  return y;
}

/// CSR arrays (indptr, indices, data) of a Csr, viewing its storage (kept alive by `self`).
py::tuple csr_arrays(const Csr& A, py::handle self) {
  return py::make_tuple(view_vector(A.pattern().row_ptr, self), view_vector(A.pattern().col_idx, self),
                        view_vector(A.values(), self), py::make_tuple(A.rows(), A.cols()));
}
/// BSR arrays (indptr, indices, data as blocks x 3 x 3) of a Bcsr, viewing its storage.
py::tuple bsr_arrays(const Bcsr& A, py::handle self) {
  py::array_t<double> data({static_cast<py::ssize_t>(A.num_blocks()), py::ssize_t(3), py::ssize_t(3)},
                           {9 * sizeof(double), 3 * sizeof(double), sizeof(double)}, A.values().data(), self);
  return py::make_tuple(view_vector(A.pattern().row_ptr, self), view_vector(A.pattern().col_idx, self), data,
                        py::make_tuple(A.rows(), A.cols()));
}

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

/// A NumPy-facing copy of a Bcsr (BSR arrays owning a copy, for matrices that change later).
py::object bsr_copy(const Bcsr& A) {
  auto* owner = new Bcsr(A);
  py::capsule c(owner, [](void* p) { delete static_cast<Bcsr*>(p); });
  return bsr_arrays(*owner, c);
}
py::object csr_copy(const Csr& A) {
  auto* owner = new Csr(A);
  py::capsule c(owner, [](void* p) { delete static_cast<Csr*>(p); });
  return csr_arrays(*owner, c);
}

std::vector<char> clamp_mask(const fem::TetMesh& mesh, py::object clamp) {
  std::vector<char> mask(mesh.num_vertices(), 0);
  if (clamp.is_none()) return mask;
  if (PyCallable_Check(clamp.ptr())) {
    for (index_t v = 0; v < mesh.num_vertices(); ++v)
      mask[v] = clamp(points_array({mesh.vertices[v]})[py::make_tuple(0)]).cast<bool>();
    return mask;
  }
  const auto a = clamp.cast<py::array_t<bool, py::array::c_style | py::array::forcecast>>();
  if (a.ndim() != 1 || a.shape(0) != mesh.num_vertices())
    throw InputError("clamp: expected one boolean per mesh vertex (" + std::to_string(mesh.num_vertices()) + ") or a function of a position");
  for (index_t v = 0; v < mesh.num_vertices(); ++v) mask[v] = a.at(v);
  return mask;
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

PYBIND11_MODULE(_core, m) {
  m.doc() = "pmgkit's compiled core; use the pmgkit package";
  register_all_solvers();  // every method of this build, as in pmg compare and scenes
  m.attr("max_config_bytes") = kMaxConfigBytes;  // the longest scene file read

  // Errors: the C++ types as Python exceptions, with the same messages.
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  static py::object input_bases = py::make_tuple(error, py::handle(PyExc_ValueError));
  static py::exception<InputError> input_error(m, "InputError", input_bases.ptr());
  static py::exception<SolveError> solve_error(m, "SolveError", error.ptr());
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const SolveError& e) {
      solve_error(e.what());
    } catch (const InputError& e) {
      input_error(e.what());
    } catch (const Error& e) {
      error(e.what());
    }
  });

  // ---- solvers ----
  py::class_<PySolver>(m, "Solver")
      .def(py::init<py::tuple, const std::string&, const std::string&, std::optional<DoubleArray>>(),
           py::arg("A"), py::arg("config"), py::arg("format"), py::arg("coordinates") = py::none())
      .def(py::init<py::list, py::list, const std::string&, const std::string&, bool>(), py::arg("levels"),
           py::arg("prolongations"), py::arg("config"), py::arg("layout"), py::arg("galerkin_only"))
      .def(py::init<PyHierarchy&, const std::string&, long>(), py::arg("hierarchy"), py::arg("config"),
           py::arg("communicator"), py::keep_alive<1, 2>())
      .def("solve", &PySolver::solve, py::arg("b"), py::arg("x0") = py::none(), py::arg("tol") = py::none())
      .def("apply", &PySolver::apply, py::arg("b"))
      .def("update", &PySolver::update, py::arg("A"))
      .def("update_levels", &PySolver::update_levels, py::arg("levels"))
      .def_property_readonly("size", &PySolver::full_size)
      .def_property_readonly("name", &PySolver::name)
      .def_property_readonly("setup_seconds", &PySolver::setup_seconds)
      .def("describe", &PySolver::describe)
      .def_property_readonly("removed_nodes", [](const PySolver& s) {
        if (!s.has_levels()) return std::vector<index_t>{};
        return s.with_levels("removed_nodes", [](const mg::UserLevels& lv) { return lv.removed_nodes(); });
      })
      .def("level_matrix", [](const PySolver& s, int l) {
        return s.with_levels("level_matrix", [l](const mg::UserLevels& lv) { return bsr_copy(lv.matrix(l)); });
      })
      .def("level_prolongation", [](const PySolver& s, int l) {
        return s.with_levels("level_prolongation", [l](const mg::UserLevels& lv) { return csr_copy(lv.prolongation(l)); });
      });

  m.def("methods", [] {
    py::list out;
    for (const auto& s : registered_solvers()) {
      py::dict d;
      d["name"] = s.name, d["description"] = s.description, d["component"] = s.component;
      py::list keys;
      for (const KeyInfo& k : s.keys) {
        py::dict kd;
        kd["key"] = k.key, kd["type"] = k.type, kd["default"] = k.default_value, kd["range"] = k.range;
        kd["description"] = k.description;
        keys.append(kd);
      }
      d["keys"] = keys;
      d["uses_levels"] = s.uses_levels, d["needs_blocks"] = s.needs_blocks;
      out.append(d);
    }
    return out;
  });
  m.def("_view_addresses", [](py::tuple A) {
    ArrayCsr a = array_csr(A, "matrix");
    return py::make_tuple(reinterpret_cast<std::uintptr_t>(a.view.row_ptr), reinterpret_cast<std::uintptr_t>(a.view.col_idx),
                          reinterpret_cast<std::uintptr_t>(a.view.values));
  }, "The addresses pmgkit reads a matrix's arrays at (for checking that nothing was copied).");

  // ---- formats ----
  py::class_<Csr>(m, "Csr")
      .def(py::init([](py::tuple A) { return to_csr(array_csr(A, "matrix").view, "matrix"); }))
      .def_property_readonly("shape", [](const Csr& A) { return py::make_tuple(A.rows(), A.cols()); })
      .def_property_readonly("nnz", &Csr::nnz)
      .def("matvec", &matvec<Csr>, py::arg("x"), py::arg("out") = py::none())
      .def("arrays", [](py::object self) { return csr_arrays(self.cast<const Csr&>(), self); });
  py::class_<Bcsr>(m, "Bcsr")
      .def(py::init([](py::tuple A) {
        const Csr c = to_csr(array_csr(A, "matrix").view, "matrix");
        return Bcsr::from_csr(c);
      }))
      .def_property_readonly("shape", [](const Bcsr& A) { return py::make_tuple(A.rows(), A.cols()); })
      .def_property_readonly("num_blocks", &Bcsr::num_blocks)
      .def("matvec", &matvec<Bcsr>, py::arg("x"), py::arg("out") = py::none())
      .def("arrays", [](py::object self) { return bsr_arrays(self.cast<const Bcsr&>(), self); });
  py::class_<BinBcsr>(m, "BinBcsr")
      .def(py::init<const Bcsr&>())
      .def_property_readonly("shape", [](const BinBcsr& A) { return py::make_tuple(A.rows(), A.cols()); })
      .def_property_readonly("num_bins", &BinBcsr::num_bins)
      .def_property_readonly("padding_ratio", &BinBcsr::padding_ratio)
      .def_property_readonly("bytes_per_spmv", &BinBcsr::bytes_per_spmv)
      .def("matvec", &matvec<BinBcsr>, py::arg("x"), py::arg("out") = py::none());

  // ---- PETSc's binary format (what MatView/VecView write; loads at disk speed) ----
  m.def("read_petsc_matrix", [](const std::string& path) {
    Csr A;
    {
      py::gil_scoped_release nogil;
      A = read_petsc_binary_matrix(path);
    }
    return csr_copy(A);
  }, py::arg("path"));
  m.def("read_petsc_vector", [](const std::string& path) {
    Vector v;
    {
      py::gil_scoped_release nogil;
      v = read_petsc_binary_vector(path);
    }
    return to_numpy(std::move(v));
  }, py::arg("path"));
  m.def("write_petsc_matrix", [](const std::string& path, py::tuple A) {
    const Csr c = to_csr(array_csr(A, "matrix").view, "matrix");
    py::gil_scoped_release nogil;
    write_petsc_binary(path, c);
  }, py::arg("path"), py::arg("A"));
  m.def("write_petsc_vector", [](const std::string& path, const DoubleArray& v) {
    if (v.ndim() != 1) throw InputError("write_petsc_vector: expected a one-dimensional array");
    const Vector x = to_vector(v, v.shape(0), "vector");
    py::gil_scoped_release nogil;
    write_petsc_binary(path, x);
  }, py::arg("path"), py::arg("v"));

  // ---- FEM ----
  py::class_<fem::Material>(m, "Material")
      .def(py::init([](double young, double poisson, double density) {
             fem::Material mat{young, poisson, density};
             mat.check();
             return mat;
           }),
           py::arg("young") = 500e3, py::arg("poisson") = 0.3, py::arg("density") = 1e3)
      .def_readonly("young", &fem::Material::young)
      .def_readonly("poisson", &fem::Material::poisson)
      .def_readonly("density", &fem::Material::density);

  py::class_<fem::TetMesh, std::shared_ptr<fem::TetMesh>>(m, "Mesh")
      .def(py::init([](const DoubleArray& vertices, py::array_t<long long, py::array::c_style | py::array::forcecast> tets,
                       bool fix_orientation) {
             fem::TetMesh mesh;
             mesh.vertices = points_of(vertices, "vertices");
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
           py::arg("vertices"), py::arg("tets"), py::arg("fix_orientation") = false)
      .def_static("read", [](const std::string& path) {
        return std::make_shared<fem::TetMesh>(checked_mesh(fem::read_mesh(path), false));
      }, py::arg("path"))
      .def_static("box", [](int nx, int ny, int nz, double lx, double ly, double lz) {
        return std::make_shared<fem::TetMesh>(fem::box_mesh_24(nx, ny, nz, lx, ly, lz));
      }, py::arg("nx"), py::arg("ny"), py::arg("nz"), py::arg("lx") = 1.0, py::arg("ly") = 1.0, py::arg("lz") = 1.0)
      .def_property_readonly("vertices", [](const fem::TetMesh& mesh) { return points_array(mesh.vertices); })
      .def_property_readonly("tets", [](const fem::TetMesh& mesh) {
        py::array_t<index_t> a({static_cast<py::ssize_t>(mesh.num_tets()), py::ssize_t(4)});
        auto w = a.mutable_unchecked<2>();
        for (index_t e = 0; e < mesh.num_tets(); ++e)
          for (int k = 0; k < 4; ++k) w(e, k) = mesh.tets[e][k];
        return a;
      })
      .def_property_readonly("num_vertices", &fem::TetMesh::num_vertices)
      .def_property_readonly("num_tets", &fem::TetMesh::num_tets);

  py::class_<PyModel>(m, "ElasticModel")
      .def(py::init<std::shared_ptr<const fem::TetMesh>, int, const fem::Material&>(), py::arg("mesh"),
           py::arg("degree"), py::arg("material") = fem::Material{})
      .def_property_readonly("num_nodes", [](PyModel& s) { return s.m().num_nodes(); })
      .def_property_readonly("num_dofs", [](PyModel& s) { return s.m().num_dofs(); })
      .def_property_readonly("num_free_dofs", [](PyModel& s) { return s.m().num_free_dofs(); })
      .def_property_readonly("degree", [](PyModel& s) { return s.m().space().degree(); })
      .def("node_positions", [](PyModel& s) { return node_positions(s.m()); })
      .def("fix_nodes", [](PyModel& s, std::vector<index_t> nodes) {
        for (index_t a : nodes)
          if (a < 0 || a >= s.m().num_nodes()) throw InputError("fix_nodes: node " + std::to_string(a) + " out of range");
        s.m().fix_nodes(nodes);
      })
      .def("fix_vertices", [](PyModel& s, py::object clamp) { s.m().fix_vertices(clamp_mask(s.m().space().mesh(), clamp)); })
      .def_property_readonly("num_fixed", [](PyModel& s) { return s.m().num_fixed(); })
      .def("stiffness", [](PyModel& s) {
        Bcsr K = s.m().assembler().make_matrix();
        {
          py::gil_scoped_release nogil;
          s.m().assemble(nullptr, Vector(), K, nullptr);
        }
        return bsr_copy(K);
      })
      .def("mass", [](PyModel& s) {
        Bcsr M = s.m().assembler().make_matrix();
        {
          py::gil_scoped_release nogil;
          s.m().assemble_mass(M);
        }
        return bsr_copy(M);
      })
      .def("gravity", [](PyModel& s, std::vector<double> g) { return to_numpy(s.m().gravity(vec3(g, "gravity"))); })
      .def("point_force", [](PyModel& s, std::vector<double> x, std::vector<double> F) {
        Vector f = Vector::Zero(s.m().num_dofs());
        s.m().add_point_force(f, vec3(x, "point"), vec3(F, "force"));
        return to_numpy(std::move(f));
      })
      .def("traction", [](PyModel& s, std::function<bool(py::array_t<double>)> on_face, std::vector<double> t) {
        Vector f = Vector::Zero(s.m().num_dofs());
        const double area = s.m().add_traction(f, [&](const fem::Vec3& X) {
          return on_face(points_array({X})[py::make_tuple(0)].cast<py::array_t<double>>());
        }, vec3(t, "traction"));
        return py::make_tuple(to_numpy(std::move(f)), area);
      })
      .def("restrict_to_free", [](PyModel& s, const DoubleArray& u) {
        return to_numpy(s.m().restrict_to_free(to_vector(u, s.m().num_dofs(), "full vector")));
      })
      .def("expand", [](PyModel& s, const DoubleArray& u) {
        return to_numpy(s.m().expand(to_vector(u, s.m().num_free_dofs(), "free vector"), Vector()));
      })
      .def("free_positions", [](PyModel& s) { return to_numpy(s.m().free_positions()); })
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
      }, py::arg("u"), py::arg("points"))
      .def("solve_static", [](PyModel& s, const DoubleArray& f, bool corotational) {
        const Vector ff = to_vector(f, s.m().num_dofs(), "force (full vector)");
        fem::StaticResult r;
        {
          py::gil_scoped_release nogil;
          r = fem::solve_static(s.m(), ff, corotational);
        }
        return py::make_tuple(to_numpy(std::move(r.u)), r.iterations);
      }, py::arg("f"), py::arg("corotational") = false);

  py::class_<PyHierarchy>(m, "DegreeHierarchy")
      .def(py::init([](std::shared_ptr<const fem::TetMesh> mesh, int degree, const fem::Material& material, py::object clamp) {
             if (degree < 1 || degree > 3) throw InputError("degree must be 1, 2 or 3, got " + std::to_string(degree));
             material.check();
             const std::vector<char> mask = clamp_mask(*mesh, clamp);
             // The hierarchy asks by rest position: the clamped vertices' positions, looked up.
             std::set<std::array<double, 3>> clamped;
             for (index_t v = 0; v < mesh->num_vertices(); ++v)
               if (mask[v]) clamped.insert({mesh->vertices[v].x(), mesh->vertices[v].y(), mesh->vertices[v].z()});
             auto h = std::make_unique<fem::DegreeHierarchy>(*mesh, degree, material, [&](const fem::Vec3& X) {
               return clamped.count({X.x(), X.y(), X.z()}) > 0;
             });
             PyHierarchy out{mesh, std::move(h)};
             py::gil_scoped_release nogil;
             out.h->assemble(nullptr);
             return out;
           }),
           py::arg("mesh"), py::arg("degree"), py::arg("material") = fem::Material{}, py::arg("clamp") = py::none())
      .def_property_readonly("num_levels", [](const PyHierarchy& s) { return s.h->num_levels(); })
      .def("matrix", [](const PyHierarchy& s, int l) { return bsr_copy(s.h->matrix(l)); })
      .def("prolongation", [](const PyHierarchy& s, int l) { return csr_copy(s.h->prolongation(l)); })
      .def("free_positions", [](const PyHierarchy& s) { return to_numpy(s.h->finest().free_positions()); })
      .def("restrict_to_free", [](const PyHierarchy& s, const DoubleArray& u) {
        return to_numpy(s.h->finest().restrict_to_free(to_vector(u, s.h->finest().num_dofs(), "full vector")));
      })
      .def("expand", [](const PyHierarchy& s, const DoubleArray& u) {
        return to_numpy(s.h->finest().expand(to_vector(u, s.h->finest().num_free_dofs(), "free vector"), Vector()));
      })
      .def("gravity", [](const PyHierarchy& s, std::vector<double> g) { return to_numpy(s.h->finest().gravity(vec3(g, "gravity"))); });

  // ---- simulation ----
  m.def("simulate", [](const std::string& scene_json, const std::string& origin, const std::string& output_dir) {
    const sim::Scene scene = sim::parse_scene(scene_json, origin);
    py::dict out;
    sim::RunSummary r;
    std::string method, settings;
    std::vector<std::string> notes;
    {
      py::gil_scoped_release nogil;
      sim::SceneSetup setup = sim::set_up(scene);
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
    return out;
  }, py::arg("scene_json"), py::arg("origin"), py::arg("output_dir") = "");
}
