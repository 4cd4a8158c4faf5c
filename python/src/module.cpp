// pmgkit._core — the compiled half of the Python module (this file: array conversion, errors and
// solvers; formats.cpp: matrix formats and PETSc files; fem.cpp: meshes, models, hierarchies,
// scenes; study.cpp: studies). Every solver is built by the one factory
// (pmg::make_solver), every multigrid hierarchy from the user's levels by mg::UserLevels or from
// the BB degree hierarchy: this file converts arrays and errors, nothing more. The SciPy side
// (sparse formats, LinearOperator, dict configs) is pmgkit/__init__.py.
//
// Arrays: matrices arrive as CSR arrays (indptr, indices: int32 or int64; data: float64) read in
// place through a CsrView; results leave as NumPy arrays that own pmgkit's buffers (no copy).
// Right-hand sides are copied once into pmgkit's vector type (O(n), next to a solve's O(nnz·its)).
// The GIL is released during set-up, updates, solves, products, assembly and simulation: the
// caller must not modify the arrays it passed while such a call runs in another thread.
#include "pmg/fem/hierarchy.hpp"
#include "pmg/sparse/defaults.hpp"
#include "pmg/solvers.hpp"
#include "pmg/multigrid/user_levels.hpp"
#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/csr_view.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/timer.hpp"

#include "common.hpp"

#include <cstring>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace py = pybind11;
using namespace pmg;
using namespace pmg::python;

// ---- shared with fem.cpp (common.hpp) ----

namespace pmg::python {

Vector to_vector(const DoubleArray& a, Eigen::Index n, const std::string& who) {
  return view_of(a, n, who);
}

Eigen::Map<const Vector> view_of(const DoubleArray& a, Eigen::Index n, const std::string& who) {
  if (a.ndim() != 1 || a.shape(0) != n)
    throw InputError(who + " has shape " + std::string(py::str(a.attr("shape"))) + ", expected (" +
                     std::to_string(n) + ",)");
  return Eigen::Map<const Vector>(a.data(), n);
}

Eigen::Map<Vector> writable_view(py::array& a, Eigen::Index n, const std::string& who) {
  if (!py::isinstance<py::array_t<double>>(a) || !a.dtype().is(py::dtype::of<double>()))
    throw InputError(who + " must be a float64 array (it is written in place), not " + std::string(py::str(a.dtype())));
  if (a.ndim() != 1 || a.shape(0) != n)
    throw InputError(who + " has shape " + std::string(py::str(a.attr("shape"))) + ", expected (" +
                     std::to_string(n) + ",)");
  if (!(a.flags() & py::array::c_style) || !a.writeable())
    throw InputError(who + " must be contiguous and writeable (it is written in place)");
  return Eigen::Map<Vector>(static_cast<double*>(a.mutable_data()), n);
}

/// A NumPy array owning `v`'s buffer (moved, not copied).
py::array_t<double> to_numpy(Vector&& v) {
  auto* owner = new Vector(std::move(v));
  py::capsule free_it(owner, [](void* p) { delete static_cast<Vector*>(p); });
  return py::array_t<double>({owner->size()}, {sizeof(double)}, owner->data(), free_it);
}

/// `a`, read-only when `writeable` is false.
template <class T>
py::array_t<T> with_write(py::array_t<T> a, bool writeable) {
  if (!writeable) a.attr("setflags")(py::arg("write") = false);
  return a;
}

py::tuple csr_arrays(const Csr& A, py::handle self, bool writeable) {
  return py::make_tuple(with_write(view_vector(A.pattern().row_ptr, self), writeable),
                        with_write(view_vector(A.pattern().col_idx, self), writeable), view_vector(A.values(), self),
                        py::make_tuple(A.rows(), A.cols()));
}
py::tuple bsr_arrays(const Bcsr& A, py::handle self, bool writeable) {
  py::array_t<double> data({static_cast<py::ssize_t>(A.num_blocks()), py::ssize_t(3), py::ssize_t(3)},
                           {9 * sizeof(double), 3 * sizeof(double), sizeof(double)}, A.values().data(), self);
  return py::make_tuple(with_write(view_vector(A.pattern().row_ptr, self), writeable),
                        with_write(view_vector(A.pattern().col_idx, self), writeable), data,
                        py::make_tuple(A.rows(), A.cols()));
}

/// A NumPy-facing copy of a Bcsr (BSR arrays owning a copy, for matrices that change later).
py::object bsr_copy(const Bcsr& A) {
  // Its own pattern too (a Bcsr copy shares its pattern): the caller may change every array.
  auto* owner = new Bcsr(std::make_shared<const BlockPattern>(A.pattern()), A.values());
  py::capsule c(owner, [](void* p) { delete static_cast<Bcsr*>(p); });
  return bsr_arrays(*owner, c, true);
}
py::object csr_copy(const Csr& A) {
  auto* owner = new Csr(std::make_shared<const CsrPattern>(A.pattern()), A.values());
  py::capsule c(owner, [](void* p) { delete static_cast<Csr*>(p); });
  return csr_arrays(*owner, c, true);
}

// ---- arrays ------------------------------------------------------------------------------------

namespace {
int index_bytes(const py::array& a, const std::string& who) {
  if (a.ndim() != 1 || !(a.flags() & py::array::c_style))
    throw InputError(who + ": expected a contiguous one-dimensional integer array");
  const auto k = a.dtype().kind();
  const char order = a.dtype().attr("byteorder").cast<std::string>()[0];
  const bool big_machine = py::module_::import("sys").attr("byteorder").cast<std::string>() == "big";
  if ((order == '>' && !big_machine) || (order == '<' && big_machine))
    throw InputError(who + ": indices must be in the machine's byte order, got " + std::string(py::str(a.dtype())));
  if ((k == 'i' || k == 'u') && (a.itemsize() == 4 || a.itemsize() == 8) && !(k == 'u' && a.itemsize() == 8))
    return static_cast<int>(a.itemsize());
  throw InputError(who + ": indices must be int32 or int64, got " + std::string(py::str(a.dtype())));
}
}  // namespace

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

void check_format_name(const std::string& format) {
  if (format != "auto" && format != "csr" && format != "bcsr" && format != "bin-bcsr")
    throw InputError("format: expected auto, csr, bcsr or bin-bcsr, got '" + format + "'");
}

std::string matrix_format(const std::string& format, const Csr& A) {
  check_format_name(format);
  if (format == "auto") return reads_as_blocks(A) ? "bcsr" : "csr";
  if (format != "csr" && A.rows() % 3 != 0)
    throw InputError("format " + format + ": the size " + std::to_string(A.rows()) + " is not divisible by 3 (3x3 blocks)");
  return format;
}

Csr symmetric_csr(const CsrView& view) {
  if (view.rows != view.cols)
    throw InputError("matrix: must be square, is " + std::to_string(view.rows) + "x" + std::to_string(view.cols));
  Csr csr = to_csr(view, "matrix");
  if (!csr.is_symmetric(1e-12)) throw InputError("matrix: not symmetric (the solvers need a symmetric positive definite matrix)");
  return csr;
}

}  // namespace pmg::python

namespace {

// ---- solvers -------------------------------------------------------------------------------------

/// One solver from the factory on a user's matrix (or user levels), owning its operator.
class PySolver {
 public:
  /// A single matrix; format auto (BCSR when the matrix reads as 3x3 blocks of interleaved
  /// unknowns, reads_as_blocks(); CSR otherwise) | csr | bcsr | bin-bcsr. A method that reads 3x3
  /// blocks is refused a matrix that reads as component-major or as a scalar system, unless the
  /// config declares its layout.
  PySolver(py::tuple A, const std::string& config_json, const std::string& format,
           std::optional<DoubleArray> coordinates)
      : config_(Config::from_json(config_json, "config")) {
    ArrayCsr a = array_csr(A, "matrix");
    if (a.view.rows != a.view.cols) throw InputError("matrix: must be square, is " + std::to_string(a.view.rows) + "x" + std::to_string(a.view.cols));
    method_ = config_.get_string("method", kDefaultMethod);
    check_format_name(format);
    const bool blocks = method_needs_blocks(method_);
    // A layout key declares the unknowns' order; with layout=component the factory wraps the method
    // in ComponentLayout, which permutes the scalar matrix and builds its own blocks.
    const bool declared = config_.has("layout");
    const bool component = declared && config_.get_string("layout", "interleaved") == "component";
    if (blocks && !component && format == "csr")
      throw InputError("method " + method_ + " reads 3x3 blocks: use format='bcsr' or 'auto'");
    std::string f;
    {
      py::gil_scoped_release nogil;
      csr_ = symmetric_csr(a.view);
      // Judged on the scalar matrix, before it becomes blocks (pmg/sparse/layout.hpp): one that
      // reads as component-major is named with layout=component, then one that reads as a scalar
      // system (its pattern does not fill 3x3 node blocks) with the scalar methods.
      if (blocks && !declared) check_block_reading(csr_, "method " + method_);
      // auto: a block method's matrix as blocks (it reads as blocks, checked above, or its config
      // says interleaved); under layout=component as CSR (the wrapper makes the blocks of the
      // permuted matrix); any other method's by reads_as_blocks().
      if (format != "auto") f = matrix_format(format, csr_);
      else if (component) f = "csr";
      else if (blocks) f = "bcsr";
      else f = matrix_format(format, csr_);
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
    method_ = config_.get_string("method", kDefaultLevelsMethod);
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
    method_ = config_.get_string("method", kDefaultLevelsMethod);
    config_.set_default("method", method_);
    hierarchy_ = h.h.get();
    hierarchy_lock_ = h.lock;
    context_.levels = hierarchy_;
    context_.communicator = communicator;
    coordinates_ = hierarchy_->node_coordinates(hierarchy_->num_levels() - 1);
    context_.coordinates = &coordinates_;
    build();
  }

  /// The solution is written into `out` when given (a float64 contiguous writeable array, returned
  /// as is); b and x0 are read in place where they are float64 and contiguous. With user levels the
  /// vectors are gathered to the reduced system and the solution scattered back once each; a plain
  /// matrix's solve reads and writes pmgkit vectors (one copy of b in and of x out).
  py::tuple solve(const DoubleArray& b_in, std::optional<DoubleArray> x0_in, std::optional<double> tol,
                  std::optional<py::array> out) {
    const Eigen::Index n = full_size();
    const Eigen::Map<const Vector> b_full = view_of(b_in, n, "b");
    std::optional<Eigen::Map<Vector>> x_out;
    if (out) x_out.emplace(writable_view(*out, n, "out"));
    Vector x;
    if (levels_) {
      // By name here: the reduction refuses NaN at identity rows without knowing which vector it has.
      for (Eigen::Index i = 0; i < n; ++i)
        if (!std::isfinite(b_full[i])) throw InputError("b: entry " + std::to_string(i) + " is NaN or Inf");
      x.resize(levels_->reduced_size());
      if (x0_in) {
        const Eigen::Map<const Vector> x0 = view_of(*x0_in, n, "x0");
        for (Eigen::Index i = 0; i < n; ++i)
          if (!std::isfinite(x0[i])) throw InputError("x0: entry " + std::to_string(i) + " is NaN or Inf");
      }
      if (x0_in) levels_->reduce(view_of(*x0_in, n, "x0"), x);
      else x.setZero();
    } else {
      x = x0_in ? Vector(view_of(*x0_in, n, "x0")) : Vector::Zero(n);
    }
    SolveMonitor monitor;
    SolveResult r;
    double seconds = 0, true_res = 0, setup_seconds = 0;
    std::string method;
    Vector x_full;
    {
      py::gil_scoped_release nogil;
      std::lock_guard<std::mutex> lock(mutex_);  // after the GIL is released: no lock-order cycle
      check_usable("solve");
      const auto shared = lock_hierarchy();
      // A tol for this call only (SciPy's contract): a solver with it, set up for this call; the
      // next call without tol goes back to the config's (one more set-up each way).
      std::optional<double> wanted;
      if (tol && (!config_.has("tol") || config_.get_double("tol", 0, 0, 1) != *tol)) wanted = tol;
      if (wanted != built_tol_) {
        Config c = config_.clone();
        if (wanted) {
          char text[32];
          std::snprintf(text, sizeof text, "%.17g", *wanted);
          c.set("tol", text);  // a new stopping rule: a new solver, kept only if it sets up
        }
        build_locked(c);
        built_tol_ = wanted;
      }
      Vector b(x.size());
      if (levels_) levels_->reduce(b_full, b);
      else b = b_full;
      const auto t0 = Clock::now();
      r = solver_->solve(b, x, &monitor);
      seconds = seconds_since(t0);
      Vector res(b.size());
      op_->residual(b, x, res);
      const double bn = b_full.norm();
      true_res = bn > 0 ? res.norm() / bn : res.norm();
      if (x_out) {
        if (levels_) levels_->expand(x, b_full, *x_out);
        else *x_out = x;
      } else {
        x_full = levels_ ? levels_->expand(x, b_full) : std::move(x);
      }
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
    if (out) return py::make_tuple(*out, info);
    return py::make_tuple(to_numpy(std::move(x_full)), info);
  }

  /// x = M b: the solver as a preconditioner.
  py::array_t<double> apply(const DoubleArray& b_in) {
    const Vector b_full = to_vector(b_in, full_size(), "b");
    Vector x;
    {
      py::gil_scoped_release nogil;
      std::lock_guard<std::mutex> lock(mutex_);
      check_usable("apply");
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
    const auto to_formats = [this] {
      if (bcsr_) bcsr_->set_values(csr_);
      if (bin_) bin_->update_values(*bcsr_);
    };
    to_formats();
    try {
      solver_->update();
    } catch (const std::exception& e) {
      // The solver refused the new matrix: back to the previous one and its set-up, so that the
      // solver stays as it was; if even that fails, it refuses to solve until an update succeeds.
      std::copy(previous.begin(), previous.end(), csr_.values().begin());
      to_formats();
      try {
        solver_->update();
        failed_update_.clear();
      } catch (...) {
        failed_update_ = e.what();
      }
      throw;
    }
    failed_update_.clear();
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
    levels_->set_values(views(mats));  // all or nothing: refused values leave the levels as they were
    try {
      solver_->update();
    } catch (const std::exception& e) {
      failed_update_ = e.what();  // the levels hold the new values, the set-up is partial
      throw;
    }
    failed_update_.clear();
    setup_seconds_ = seconds_since(t0);
  }

  Eigen::Index full_size() const { return levels_ ? levels_->full_size() : op_->rows(); }
  /// The format the solver's matrix is multiplied in: csr, bcsr, bin-bcsr, or matrix-free (a
  /// hierarchy's matrix-free operator).
  std::string format() const {
    std::lock_guard<std::mutex> lock(mutex_);  // a hierarchy's solver rebuilt for a new tol moves op_
    if (!op_) return "none";
    if (op_->bin_bcsr_matrix()) return "bin-bcsr";
    if (op_->bcsr_matrix()) return "bcsr";
    if (op_->csr_matrix()) return "csr";
    return "matrix-free";
  }
  /// What it is, in one line (the class's repr): method, unknowns, format, what it was built on.
  std::string repr() const {
    const std::string on = levels_ ? ", " + std::to_string(levels_->num_levels()) + " user levels"
                           : hierarchy_ ? ", a degree hierarchy of " + std::to_string(hierarchy_->num_levels()) + " levels"
                                        : std::string();
    return "<pmgkit.Solver: " + name() + ", " + grouped(full_size()) + " unknowns, " + format() + on + ">";
  }
  // These take the lock with the GIL held: no locked region ever waits for the GIL.
  std::string name() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return solver_->name();
  }
  std::string describe() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return solver_->describe();
  }
  std::vector<std::string> unused_keys() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return config_.unused_keys();
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
    auto solver = make_solver(config, context_, levels_ || hierarchy_ ? kDefaultLevelsMethod : kDefaultMethod);
    start_libraries(config);  // MPI and PETSc where the method needs them, outside its set-up time
    if (hierarchy_) op_ = &hierarchy_->bind(*solver).prepare();
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
  std::optional<double> built_tol_;  // the per-call tol solver_ was built with (none: the config's)
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
  /// Set when an update() failed part-way and the solver could not be returned to its previous
  /// set-up: solve and apply refuse until an update succeeds.
  std::string failed_update_;
  void check_usable(const char* what) const {
    if (!failed_update_.empty())
      throw InputError(std::string(what) + ": the last update failed (" + failed_update_ +
                       "); update with valid values or build a new solver");
  }
  /// Serialises the calls on this object from several Python threads (solve's rebuild for a new
  /// tol, update's new values and the solve itself must not interleave).
  mutable std::mutex mutex_;
};

}  // namespace

namespace {

/// Error, InputError and SolveError as Python exceptions, with the same messages.
void register_errors(py::module_& m) {
  // Errors: the C++ types as Python exceptions, with the same messages.
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  static py::object input_bases = py::make_tuple(error, py::handle(PyExc_ValueError));
  static py::exception<InputError> input_error(m, "InputError", input_bases.ptr());
  static py::exception<SolveError> solve_error(m, "SolveError", error.ptr());
  error.attr("__doc__") =
      "Any error of pmgkit's C++ library (a RuntimeError), with its message; InputError and SolveError "
      "are the two kinds callers usually tell apart.";
  input_error.attr("__doc__") =
      "Input pmgkit refuses before it computes (an Error and a ValueError): bad shapes, unknown or "
      "misspelt config keys, a wrong layout, a malformed or non-symmetric matrix, a matrix a method "
      "cannot read (a direct solver's zero or missing diagonal entry, a scalar system given to a block "
      "method), sizes beyond the machine.";
  solve_error.attr("__doc__") =
      "A solve that ended without a usable answer (an Error): breakdown, divergence, stagnation, the "
      "iteration limit, NaN/Inf, a direct solve that misses its tol. The message names the method and "
      "the relative residual reached.";
  // Messages may quote bytes of the caller's files: decoded with \xNN for bytes that are not UTF-8,
  // never lost (PyErr_SetString would replace an undecodable message by an empty exception).
  py::register_exception_translator([](std::exception_ptr p) {
    const auto raise = [](PyObject* type, const char* what) {
      PyObject* text = PyUnicode_DecodeUTF8(what, static_cast<Py_ssize_t>(std::strlen(what)), "backslashreplace");
      if (!text) {
        PyErr_Clear();
        PyErr_SetString(type, "(an error message that could not be decoded)");
        return;
      }
      PyErr_SetObject(type, text);
      Py_DECREF(text);
    };
    try {
      if (p) std::rethrow_exception(p);
    } catch (const SolveError& e) {
      raise(solve_error.ptr(), e.what());
    } catch (const InputError& e) {
      raise(input_error.ptr(), e.what());
    } catch (const Error& e) {
      raise(error.ptr(), e.what());
    }
  });
}

/// Solver (matrices, user levels or an FEM hierarchy) and the registry's methods.
void register_solver(py::module_& m) {
  // ---- solvers ----
  py::class_<PySolver>(m, "Solver",
                       "A solver from pmgkit's factory, set up on a matrix, on user multigrid levels or on a "
                       "DegreeHierarchy (the core of pmgkit.Solver: make_solver, multigrid and "
                       "DegreeHierarchy.solver build it, with SciPy arrays turned into CSR tuples).")
      .def(py::init<py::tuple, const std::string&, const std::string&, std::optional<DoubleArray>>(),
           py::arg("A"), py::arg("config"), py::arg("format") = "auto", py::arg("coordinates") = py::none(),
           "A solver on one matrix.\n\n"
           "A: (indptr, indices, data, (rows, cols)), CSR arrays read in place (symmetric, square).\n"
           "config: the factory's config as JSON text.\n"
           "format: auto (3x3 blocks when the matrix reads as blocks of interleaved unknowns) | csr | bcsr | "
           "bin-bcsr.\n"
           "coordinates: x, y, z per node for BoomerAMG's or GAMG's rigid-body modes, or None.\n"
           "Raises InputError for a bad matrix or config, or a block method on a matrix that does not read "
           "as 3x3 blocks.")
      .def(py::init<py::list, py::list, const std::string&, const std::string&, bool>(), py::arg("levels"),
           py::arg("prolongations"), py::arg("config"), py::arg("layout") = "interleaved",
           py::arg("galerkin_only") = false,
           "Multigrid on user levels.\n\n"
           "levels: CSR tuples, coarsest first (just the finest with galerkin_only).\n"
           "prolongations: CSR tuples P_1 .. P_L-1 (level l-1 -> l; per node or per dof).\n"
           "config: the factory's config as JSON text (default method mgpcg).\n"
           "layout: interleaved (x0 y0 z0 x1 ...) or component (x0 x1 ... y0 ...).\n"
           "galerkin_only: the lower levels are Galerkin products of the finest.")
      .def(py::init<PyHierarchy&, const std::string&, long>(), py::arg("hierarchy"), py::arg("config"),
           py::arg("communicator") = -1, py::keep_alive<1, 2>(),
           "A factory method on a DegreeHierarchy's finest free unknowns (multigrid methods on its degrees).\n\n"
           "config: the factory's config as JSON text (default method mgpcg).\n"
           "communicator: an MPI communicator's Fortran handle for petsc-mgpcg (-1: MPI_COMM_WORLD).")
      .def("solve", &PySolver::solve, py::arg("b"), py::arg("x0") = py::none(), py::arg("tol") = py::none(),
           py::arg("out") = py::none(),
           "Solves A x = b; returns (x, info).\n\n"
           "b, x0: float64 vectors of the system's size (read in place when contiguous); x0 None: zero.\n"
           "tol: a tolerance relative to ||b|| for this call only (None: the config's).\n"
           "out: a contiguous writeable float64 array that receives x (and is returned as x).\n"
           "info: status, iterations, residual (||b - A x|| / ||b|| measured by pmgkit after the solve), "
           "rel_residual (the solver's own final relative residual; NaN where it measured none), history, "
           "history_seconds, setup_seconds, solve_seconds, method, message. See pmgkit.Solver.solve.\n"
           "Raises SolveError when the solve fails, InputError for bad vectors.")
      .def("apply", &PySolver::apply, py::arg("b"),
           "x = M b: the solver applied once from x = 0 (as a preconditioner); returns x.")
      .def("update", &PySolver::update, py::arg("A"),
           "New values on the same pattern (A: a CSR tuple with the set-up's indptr and indices); numeric "
           "set-up only. Raises InputError for another pattern or a non-symmetric matrix (the solver then "
           "stays as it was).")
      .def("update_levels", &PySolver::update_levels, py::arg("levels"),
           "New values for every user level (CSR tuples, coarsest first, their patterns unchanged); "
           "numeric set-up only.")
      .def_property_readonly("size", &PySolver::full_size, "Unknowns of the system it solves (b's length).")
      .def_property_readonly("name", &PySolver::name, "The method's name (cg, mgpcg, ...).")
      .def_property_readonly("format", &PySolver::format,
                             "The format its matrix is multiplied in: csr, bcsr, bin-bcsr, or matrix-free.")
      .def_property_readonly("setup_seconds", &PySolver::setup_seconds, "Seconds of the last set-up or update.")
      .def("describe", &PySolver::describe, "The solver's settings in words (preconditioner, smoother, ...).")
      .def_property_readonly("unused_keys", [](const PySolver& s) { return s.unused_keys(); },
                             "The config's keys no part of the solver read.")
      .def_property_readonly("removed_nodes", [](const PySolver& s) {
        if (!s.has_levels()) return std::vector<index_t>{};
        return s.with_levels("removed_nodes", [](const mg::UserLevels& lv) { return lv.removed_nodes(); });
      }, "Clamped nodes (identity rows) removed from each user level, coarsest first (empty without levels).")
      .def("level_matrix", [](const PySolver& s, int l) {
        return s.with_levels("level_matrix", [l](const mg::UserLevels& lv) { return bsr_copy(lv.matrix(l)); });
      }, py::arg("level"),
         "User level `level`'s matrix as the cycle sees it (free nodes, interleaved), as a copy in BSR arrays "
         "(indptr, indices, blocks, shape). Raises InputError without user levels.")
      .def("level_prolongation", [](const PySolver& s, int l) {
        return s.with_levels("level_prolongation", [l](const mg::UserLevels& lv) { return csr_copy(lv.prolongation(l)); });
      }, py::arg("level"),
         "The node prolongation from level-1 to `level` as the cycle sees it, as a copy in CSR arrays. Raises "
         "InputError without user levels.")
      .def("__repr__", &PySolver::repr);

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
  }, "Every solver method of this build, one dict each: name, description, component, keys (each a dict: "
     "key, type, default, range, description), uses_levels, needs_blocks (reads 3x3 blocks: refuses a "
     "scalar system).");
  m.def("_view_addresses", [](py::tuple A) {
    ArrayCsr a = array_csr(A, "matrix");
    return py::make_tuple(reinterpret_cast<std::uintptr_t>(a.view.row_ptr), reinterpret_cast<std::uintptr_t>(a.view.col_idx),
                          reinterpret_cast<std::uintptr_t>(a.view.values));
  }, py::arg("A"), "The addresses pmgkit reads a matrix's arrays at (for checking that nothing was copied).");
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "pmgkit's compiled core (solvers, formats, PETSc files, studies, FEM); use the pmgkit package, "
            "which takes SciPy matrices and dict configs.";
  register_all_solvers();  // every method of this build, as in pmg compare and scenes
  m.attr("max_config_bytes") = kMaxConfigBytes;  // the longest scene file read

  register_errors(m);
  register_solver(m);
  register_formats(m);
  register_petsc_files(m);
  register_study(m);
  register_distributed(m);
  register_fem(m);  // meshes, models, hierarchies and scenes (fem.cpp)
}
