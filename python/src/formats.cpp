// pmgkit._core's matrix formats (Csr, Bcsr, BinBcsr: products into NumPy arrays, views of their
// storage) and PETSc's binary files. Registered by module.cpp's PYBIND11_MODULE.
#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/csr_view.hpp"
#include "pmg/sparse/petsc_binary.hpp"

#include "common.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdio>
#include <optional>
#include <string>

namespace py = pybind11;

namespace pmg::python {

namespace {

/// y = A x into NumPy arrays, without copies (x converted only if not contiguous float64; copied
/// when it shares memory with out, so that out = x gives A x).
template <typename Op>
py::array_t<double> matvec(const Op& A, const DoubleArray& x, std::optional<py::array> out) {
  if (x.ndim() != 1 || x.shape(0) != A.cols())
    throw InputError("x has shape " + std::string(py::str(x.attr("shape"))) + ", the matrix " +
                     std::to_string(A.cols()) + " columns");
  py::array y = out ? *out : py::array_t<double>(A.rows());
  Eigen::Map<Vector> yv = writable_view(y, A.rows(), "out");
  const double* xp = x.data();
  Vector copy;
  const char* xb = reinterpret_cast<const char*>(xp);
  const char* yb = reinterpret_cast<const char*>(yv.data());
  if (xb < yb + sizeof(double) * A.rows() && yb < xb + sizeof(double) * A.cols()) {
    copy = Eigen::Map<const Vector>(xp, A.cols());
    xp = copy.data();
  }
  {
    py::gil_scoped_release nogil;
    A.multiply(xp, yv.data());
  }
  return py::reinterpret_borrow<py::array_t<double>>(y);
}

}  // namespace

void register_formats(py::module_& m) {
  // ---- formats ----
  py::class_<Csr>(m, "Csr", "pmgkit's CSR matrix (64-bit row pointers), a copy of a user's CSR arrays.")
      .def(py::init([](py::tuple A) { return to_csr(array_csr(A, "matrix").view, "matrix"); }), py::arg("A"),
           "A copy of A = (indptr, indices, data, (rows, cols)), rows sorted and duplicates summed.")
      .def_property_readonly("shape", [](const Csr& A) { return py::make_tuple(A.rows(), A.cols()); },
                             "(rows, cols)")
      .def_property_readonly("nnz", &Csr::nnz, "Entries stored.")
      .def("matvec", &matvec<Csr>, py::arg("x"), py::arg("out") = py::none(),
           "y = A x; with out= (a contiguous writeable float64 array of rows entries) written in place and "
           "returned.")
      .def("arrays", [](py::object self) { return csr_arrays(self.cast<const Csr&>(), self); },
           "(indptr, indices, data, shape) viewing pmgkit's storage (no copy; the index arrays read-only).")
      .def("__repr__", [](const Csr& A) {
        return "<pmgkit.Csr: " + grouped(A.rows()) + "x" + grouped(A.cols()) + ", " + grouped(A.nnz()) + " nonzeros>";
      });
  py::class_<Bcsr>(m, "Bcsr", "3x3-block CSR (BCSR) of interleaved unknowns (x0 y0 z0 x1 ...), from a user's CSR arrays.")
      .def(py::init([](py::tuple A) {
        const Csr c = to_csr(array_csr(A, "matrix").view, "matrix");
        return Bcsr::from_csr(c);
      }), py::arg("A"),
           "The 3x3 blocks of A = (indptr, indices, data, (rows, cols)); InputError unless the size is a "
           "multiple of 3.")
      .def_property_readonly("shape", [](const Bcsr& A) { return py::make_tuple(A.rows(), A.cols()); },
                             "(rows, cols) in unknowns (3 per block row).")
      .def_property_readonly("num_blocks", &Bcsr::num_blocks, "3x3 blocks stored.")
      .def_property_readonly("bytes_per_spmv", &Bcsr::bytes_per_spmv,
                             "The least bytes one SpMV moves (9 values and a block column per block, row "
                             "pointers, x, y).")
      .def("matvec", &matvec<Bcsr>, py::arg("x"), py::arg("out") = py::none(),
           "y = A x; with out= (a contiguous writeable float64 array) written in place and returned.")
      .def("arrays", [](py::object self) { return bsr_arrays(self.cast<const Bcsr&>(), self); },
           "(indptr, indices, data as blocks x 3 x 3, shape) viewing pmgkit's storage (no copy).")
      .def("__repr__", [](const Bcsr& A) {
        return "<pmgkit.Bcsr: " + grouped(A.rows()) + "x" + grouped(A.cols()) + ", " + grouped(A.rows() / 3) +
               " block rows, " + grouped(A.num_blocks()) + " 3x3 blocks>";
      });
  py::class_<BinBcsr>(m, "BinBcsr",
                      "BIN-BCSR: a Bcsr's block rows sorted by length within windows and packed into 32-thread "
                      "bins (one per warp), `lanes` threads per block row; its products equal the Bcsr's.")
      .def(py::init([](const Bcsr& A, int lanes, index_t sort_window) {
             return BinBcsr(A, BinBcsrOptions{lanes, sort_window});
           }),
           py::arg("A"), py::arg("lanes") = 0, py::arg("sort_window") = 0,
           "The BIN-BCSR form of A (a pmgkit Bcsr). lanes: threads per block row (1, 2, 4, 8, 16 or 32; 0: "
           "chosen from the pattern). sort_window: block rows sorted by length within windows of this many "
           "(1: the original order; 0: 32 bins' worth; others rounded up to whole bins).")
      .def_property_readonly("lanes", &BinBcsr::lanes, "Threads per block row.")
      .def_property_readonly("sort_window", &BinBcsr::sort_window, "Block rows per sorting window.")
      .def_property_readonly("shape", [](const BinBcsr& A) { return py::make_tuple(A.rows(), A.cols()); },
                             "(rows, cols) in unknowns.")
      .def_property_readonly("num_bins", &BinBcsr::num_bins, "Bins (warps of 32 threads).")
      .def_property_readonly("padding_ratio", &BinBcsr::padding_ratio,
                             "Values stored, padding included, over the source matrix's values (>= 1).")
      .def_property_readonly("bytes_per_spmv", &BinBcsr::bytes_per_spmv, "The least bytes one SpMV moves.")
      .def("matvec", &matvec<BinBcsr>, py::arg("x"), py::arg("out") = py::none(),
           "y = A x; with out= (a contiguous writeable float64 array) written in place and returned.")
      .def("__repr__", [](const BinBcsr& A) {
        char padding[32];
        std::snprintf(padding, sizeof padding, "%.2f", A.padding_ratio());
        return "<pmgkit.BinBcsr: " + grouped(A.rows()) + "x" + grouped(A.cols()) + ", " + grouped(A.num_bins()) +
               " bins, " + std::to_string(A.lanes()) + " lanes per block row, padding " + padding + ">";
      });
}

/// PETSc's binary format (what MatView/VecView write; loads at disk speed).
void register_petsc_files(py::module_& m) {
  // ---- PETSc's binary format (what MatView/VecView write; loads at disk speed) ----
  m.def("read_petsc_matrix", [](const std::string& path) {
    Csr A;
    {
      py::gil_scoped_release nogil;
      A = read_petsc_binary_matrix(path);
    }
    return csr_copy(A);
  }, py::arg("path"),
  "A matrix from a PETSc binary file (what MatView writes) as CSR arrays (indptr, indices, data, shape) "
  "owning their memory. Raises InputError naming the file when it is malformed.");
  m.def("read_petsc_vector", [](const std::string& path) {
    Vector v;
    {
      py::gil_scoped_release nogil;
      v = read_petsc_binary_vector(path);
    }
    return to_numpy(std::move(v));
  }, py::arg("path"),
  "A vector from a PETSc binary file (what VecView writes) as a NumPy array. Raises InputError naming the "
  "file when it is malformed.");
  m.def("write_petsc_matrix", [](const std::string& path, py::tuple A) {
    const Csr c = to_csr(array_csr(A, "matrix").view, "matrix");
    py::gil_scoped_release nogil;
    write_petsc_binary(path, c);
  }, py::arg("path"), py::arg("A"),
  "Writes A (CSR arrays: indptr, indices, data, shape) in PETSc's binary format, to a temporary name and "
  "then renamed.");
  m.def("write_petsc_vector", [](const std::string& path, const DoubleArray& v) {
    if (v.ndim() != 1) throw InputError("write_petsc_vector: expected a one-dimensional array");
    const Vector x = to_vector(v, v.shape(0), "vector");
    py::gil_scoped_release nogil;
    write_petsc_binary(path, x);
  }, py::arg("path"), py::arg("v"),
  "Writes v (a one-dimensional float64 array) in PETSc's binary format, to a temporary name and then "
  "renamed.");
}


}  // namespace pmg::python
