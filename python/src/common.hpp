// What the two halves of pmgkit._core share (module.cpp: solvers, formats, PETSc files; fem.cpp:
// meshes, models, hierarchies, scenes): array conversions and the degree hierarchy's holder.
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/mesh.hpp"
#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/csr_view.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace pmg::python {

namespace py = pybind11;

/// A float64 NumPy array, converted only when not already contiguous float64.
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// A's n entries as pmgkit's vector (one copy); InputError naming `who` for another shape.
Vector to_vector(const DoubleArray& a, Eigen::Index n, const std::string& who);
/// A's n entries viewed in place (no copy); InputError naming `who` for another shape.
Eigen::Map<const Vector> view_of(const DoubleArray& a, Eigen::Index n, const std::string& who);
/// A caller's float64, contiguous, writeable array of n entries viewed for writing; InputError
/// naming `who` otherwise (never a converted copy that the caller would not see).
Eigen::Map<Vector> writable_view(py::array& a, Eigen::Index n, const std::string& who);
/// A NumPy array owning `v`'s buffer (moved, not copied).
py::array_t<double> to_numpy(Vector&& v);
/// CSR arrays (indptr, indices, data, shape) of a Csr, viewing its storage (kept alive by `self`);
/// the index arrays read-only unless `writeable` (a live matrix's products trust its indices; its
/// values may be changed in place).
py::tuple csr_arrays(const Csr& A, py::handle self, bool writeable = false);
/// BSR arrays (indptr, indices, data as blocks x 3 x 3, shape) of a Bcsr, viewing its storage;
/// the index arrays read-only unless `writeable`.
py::tuple bsr_arrays(const Bcsr& A, py::handle self, bool writeable = false);
/// BSR arrays owning a copy of A, pattern and values (for matrices that change later; the caller
/// may change every array).
py::object bsr_copy(const Bcsr& A);
/// CSR arrays owning a copy of A.
py::object csr_copy(const Csr& A);

/// A NumPy array viewing a std::vector held by `base` (no copy; base is kept alive by the array).
template <typename T>
py::array_t<T> view_vector(const std::vector<T>& v, py::handle base) {
  return py::array_t<T>({static_cast<py::ssize_t>(v.size())}, {sizeof(T)}, v.data(), base);
}

/// A degree hierarchy with the mesh it refers to; its solvers take `lock` while they build or
/// solve (they share its operators).
struct PyHierarchy {
  std::shared_ptr<const fem::TetMesh> mesh;
  std::unique_ptr<fem::DegreeHierarchy> h;
  std::shared_ptr<std::mutex> lock = std::make_shared<std::mutex>();
};

/// Registers Material, Mesh, ElasticModel, DegreeHierarchy and simulate (fem.cpp).
void register_fem(py::module_& m);
/// Registers study_matrix, study_hierarchy and study_scene (study.cpp).
void register_study(py::module_& m);
/// pmgkit.solve_distributed (distributed.cpp).
void register_distributed(py::module_& m);
/// Registers Csr, Bcsr and BinBcsr (formats.cpp).
void register_formats(py::module_& m);
/// Registers read_petsc_matrix/vector and write_petsc_matrix/vector (formats.cpp).
void register_petsc_files(py::module_& m);

/// A CSR matrix handed over as (indptr, indices, data, (rows, cols)): the arrays are read in place.
/// The Python objects are held so that the view stays valid as long as this lives.
struct ArrayCsr {
  py::array indptr, indices, data;
  CsrView view;
};
/// The arrays of `m` = (indptr, indices, data, shape) viewed in place, checked (InputError naming
/// `who`: lengths, dtypes, byte order, index range).
ArrayCsr array_csr(py::tuple m, const std::string& who);
/// InputError unless `format` is auto, csr, bcsr or bin-bcsr (checked before any conversion).
void check_format_name(const std::string& format);
/// The format a user's matrix A is multiplied in: auto (BCSR when A reads as 3x3 blocks of
/// interleaved unknowns, reads_as_blocks() of pmg/sparse/layout.hpp; CSR otherwise, a scalar
/// matrix whose size happens to be a multiple of 3 included) | csr | bcsr | bin-bcsr, the block
/// formats only for sizes divisible by 3 (InputError otherwise, and for another name).
std::string matrix_format(const std::string& format, const Csr& A);
/// A user's matrix as CSR, refused (InputError) when not square or not symmetric.
Csr symmetric_csr(const CsrView& view);

/// n with its thousands separated by commas (1,234,567), for the classes' reprs.
inline std::string grouped(long long n) {
  const std::string digits = std::to_string(n < 0 ? -n : n);
  std::string out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return n < 0 ? "-" + out : out;
}

}  // namespace pmg::python
