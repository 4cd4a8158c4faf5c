#include "pmg/sparse/generators.hpp"
#include "pmg/sparse/petsc_binary.hpp"

#include <catch2/catch.hpp>

#include <fstream>
#include <limits>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <sstream>

using namespace pmg;

namespace {
/// Big-endian bytes of 32-bit integers and doubles, for hand-made files.
struct Bytes {
  std::string s;
  Bytes& i(std::int32_t v) {
    for (int k = 3; k >= 0; --k) s.push_back(static_cast<char>((static_cast<std::uint32_t>(v) >> (8 * k)) & 0xff));
    return *this;
  }
  Bytes& d(double v) {
    std::uint64_t u;
    std::memcpy(&u, &v, 8);
    for (int k = 7; k >= 0; --k) s.push_back(static_cast<char>((u >> (8 * k)) & 0xff));
    return *this;
  }
};
std::string error_of(const std::string& bytes, bool vector = false) {
  std::istringstream in(bytes);
  try {
    if (vector)
      read_petsc_binary_vector(in, "f");
    else
      read_petsc_binary_matrix(in, "f");
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}
}  // namespace

TEST_CASE("PETSc binary: a matrix and a vector round-trip exactly", "[sparse][petsc_binary]") {
  const Csr A = spring_lattice(4).to_csr();
  const Vector v = Vector::LinSpaced(A.rows(), -1.0, 1.0 / 3.0);
  const std::string m = "petsc_binary_test.mat", f = "petsc_binary_test.vec";
  write_petsc_binary(m, A);
  write_petsc_binary(f, v);
  const Csr B = read_petsc_binary_matrix(m);
  const Vector w = read_petsc_binary_vector(f);
  CHECK(B.rows() == A.rows());
  CHECK(B.pattern().row_ptr == A.pattern().row_ptr);
  CHECK(B.pattern().col_idx == A.pattern().col_idx);
  CHECK(B.values() == A.values());  // bit for bit
  CHECK(w == v);
  std::remove(m.c_str());
  std::remove(f.c_str());
  // a vector the reader would refuse is not written
  Vector bad = v;
  bad[1] = std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH(write_petsc_binary(f, bad), Catch::Contains("vector entry 1 is NaN or Inf"));
  CHECK(!std::ifstream(f).good());
}

TEST_CASE("PETSc binary: a hand-made file in PETSc's layout, unsorted row, is read", "[sparse][petsc_binary]") {
  // [[2, 0, 1], [0, 3, 0]] with row 0 listed as columns 2, 0
  Bytes b;
  b.i(1211216).i(2).i(3).i(3).i(2).i(1).i(2).i(0).i(1).d(1.0).d(2.0).d(3.0);
  std::istringstream in(b.s);
  const Csr A = read_petsc_binary_matrix(in, "hand");
  const auto E = A.to_eigen();
  CHECK(E.coeff(0, 0) == 2.0);
  CHECK(E.coeff(0, 2) == 1.0);
  CHECK(E.coeff(1, 1) == 3.0);
  CHECK(A.nnz() == 3);
}

TEST_CASE("PETSc binary: damaged files are named errors, never large allocations", "[sparse][petsc_binary]") {
  CHECK_THAT(error_of(""), Catch::Contains("f: file ends inside the header"));
  CHECK_THAT(error_of(Bytes().i(1211214).i(1).d(0).s), Catch::Contains("a PETSc vector, not a matrix"));
  CHECK_THAT(error_of(Bytes().i(42).s), Catch::Contains("not a PETSc binary matrix"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(1).i(1).i(-1).s), Catch::Contains("dense"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(2000000000).i(2000000000).i(1).s),
             Catch::Contains("row count 2000000000 is more than"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(1).i(1).i(2000000000).i(1).s),
             Catch::Contains("nonzero count 2000000000 is more than"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(1).i(1).i(1).i(2).i(0).d(1).s),
             Catch::Contains("row 0 has 2 entries"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(2).i(2).i(1).i(1).i(1).i(0).d(1).s),
             Catch::Contains("add up to 2"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(1).i(2).i(1).i(1).i(5).d(1).s),
             Catch::Contains("column 5 outside 0..1"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(1).i(2).i(2).i(2).i(1).i(1).d(1).d(2).s),
             Catch::Contains("column 1 appears twice"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(1).i(1).i(1).i(1).i(0).d(std::nan("")).s),
             Catch::Contains("not finite"));
  CHECK_THAT(error_of(Bytes().i(1211216).i(1).i(1).i(1).i(1).i(0).s), Catch::Contains("nonzero count 1 is more than the 0"));
  CHECK_THAT(error_of(Bytes().i(1211214).i(3).d(1).s, true), Catch::Contains("vector length 3 is more than the 1"));
  CHECK_THAT(error_of(Bytes().i(1211214).i(-3).s, true), Catch::Contains("negative vector length"));
  CHECK_THAT(error_of(Bytes().i(1211216).s, true), Catch::Contains("a PETSc matrix, not a vector"));
  CHECK_THROWS_WITH(read_petsc_binary_matrix("/nonexistent/a.petsc"), Catch::Contains("cannot open"));
}
