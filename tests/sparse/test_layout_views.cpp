// Blocks where the data has them (pmg::reads_as_blocks, BlockInput: a block method set up on a
// scalar Csr), layout mistakes named in both directions, and the solver entry points on the
// caller's arrays (setup/update with a CsrView, solve on pointers).
#include "pmg/sparse/generators.hpp"
#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/factory.hpp"

#include <catch2/catch.hpp>

#include <cstdint>
#include <vector>

using namespace pmg;

namespace {

/// The 5-point Laplacian on an m x m grid: a scalar system (m*m unknowns).
Csr poisson(index_t m) {
  std::vector<Triplet> t;
  auto id = [m](index_t i, index_t j) { return i * m + j; };
  for (index_t i = 0; i < m; ++i)
    for (index_t j = 0; j < m; ++j) {
      t.emplace_back(id(i, j), id(i, j), 4.0);
      if (i > 0) t.emplace_back(id(i, j), id(i - 1, j), -1.0);
      if (i + 1 < m) t.emplace_back(id(i, j), id(i + 1, j), -1.0);
      if (j > 0) t.emplace_back(id(i, j), id(i, j - 1), -1.0);
      if (j + 1 < m) t.emplace_back(id(i, j), id(i, j + 1), -1.0);
    }
  return Csr::from_triplets(m * m, m * m, t);
}

/// The interleaved matrix A permuted to component-major order (x0 x1 ... y0 ... z0 ...).
Csr component_major(const Csr& A) {
  const index_t n = A.rows(), m = n / 3;
  auto to_component = [m](index_t i) { return (i % 3) * m + i / 3; };
  std::vector<Triplet> t;
  const CsrPattern& p = A.pattern();
  for (index_t i = 0; i < n; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      t.emplace_back(to_component(i), to_component(p.col_idx[k]), A.values()[k]);
  return Csr::from_triplets(n, n, t);
}

/// A copy of A without its exact zeros (as scipy's eliminate_zeros leaves a matrix).
Csr without_zeros(const Csr& A) {
  std::vector<Triplet> t;
  const CsrPattern& p = A.pattern();
  for (index_t i = 0; i < A.rows(); ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      if (A.values()[k] != 0.0) t.emplace_back(i, p.col_idx[k], A.values()[k]);
  return Csr::from_triplets(A.rows(), A.cols(), t);
}

std::unique_ptr<Solver> make(const std::vector<std::string>& pairs) {
  return make_solver(Config::from_pairs(pairs, "test"));
}

}  // namespace

TEST_CASE("reads_as_blocks: 3-component systems read as blocks, scalar stencils do not", "[sparse][layout]") {
  const Csr lattice = spring_lattice(5).to_csr();
  CHECK(reads_as_blocks(lattice));
  CHECK(reads_as_blocks(without_zeros(lattice)));
  CHECK_FALSE(reads_as_blocks(poisson(30)));  // 900 unknowns: a multiple of 3, still scalar
  CHECK_FALSE(reads_as_blocks(poisson(6)));   // 36
  CHECK_FALSE(reads_as_blocks(poisson(5)));   // 25: not a multiple of 3
  CHECK_FALSE(reads_as_blocks(component_major(lattice)));
}

TEST_CASE("A block method on a scalar Csr: blocks where the pattern has them, refused otherwise",
          "[sparse][layout]") {
  const Csr A = spring_lattice(5).to_csr();
  const Vector b = Vector::LinSpaced(A.rows(), 1.0, 2.0);
  for (const char* method : {"block-jacobi-pcg", "mcg"}) {
    INFO(method);
    auto on_csr = make({std::string("method=") + method, "tol=1e-10"});
    on_csr->setup(A);
    CHECK_THAT(on_csr->describe(), Catch::StartsWith("scalar CSR input read as 3x3 blocks"));
    Vector x;
    const SolveResult r = on_csr->solve(b, x);
    // The same iterations as on the Bcsr the user would otherwise have to build.
    const Bcsr blocks = Bcsr::from_csr(A);
    auto on_bcsr = make({std::string("method=") + method, "tol=1e-10"});
    on_bcsr->setup(blocks);
    Vector y;
    CHECK(on_bcsr->solve(b, y).iterations == r.iterations);
    CHECK((x - y).norm() <= 1e-12 * y.norm());
    // update(): new values through the same copy.
    Csr doubled = A;
    for (double& v : doubled.values()) v *= 2;
    auto s = make({std::string("method=") + method, "tol=1e-10"});
    s->setup(doubled);
    for (double& v : doubled.values()) v /= 2;
    s->update();
    Vector z;
    s->solve(b, z);
    CHECK((z - y).norm() <= 1e-8 * y.norm());
  }
  const Csr P = poisson(30);
  CHECK_THROWS_WITH(make({"method=block-jacobi-pcg"})->setup(P),
                    Catch::Contains("reads as a scalar system") && Catch::Contains("jacobi-pcg"));
  CHECK_THROWS_WITH(make({"method=cg", "preconditioner=block-jacobi"})->setup(P),
                    Catch::Contains("preconditioner block-jacobi") && Catch::Contains("scalar system"));
  CHECK_THROWS_WITH(make({"method=mcg"})->setup(component_major(A)), Catch::Contains("layout=component"));
  // layout=interleaved given explicitly declares the blocks: no judgement of the pattern.
  auto declared = make({"method=block-jacobi-pcg", "layout=interleaved", "tol=1e-8"});
  declared->setup(P);
  CHECK_THAT(declared->describe(), Catch::StartsWith("scalar CSR input read as 3x3 blocks"));
  // A refused second set-up leaves no inner solver reading a freed copy: the first one still solves.
  auto twice = make({"method=block-jacobi-pcg", "tol=1e-10"});
  twice->setup(A);
  CHECK_THROWS_AS(twice->setup(P), InputError);
  CHECK_FALSE(twice->is_set_up());
  // Scalar methods take the scalar system as it is.
  auto scalar = make({"method=jacobi-pcg", "tol=1e-8"});
  scalar->setup(P);
  Vector x;
  CHECK(scalar->solve(Vector::Ones(P.rows()), x).status == SolveStatus::converged);
}

TEST_CASE("layout=component given to an interleaved matrix is refused, naming the reading", "[sparse][layout]") {
  const Csr A = spring_lattice(5).to_csr();
  CHECK_THROWS_WITH(make({"method=block-jacobi-pcg", "layout=component"})->setup(A),
                    Catch::Contains("reads as interleaved") && Catch::Contains("leave layout out"));
  // The right layout solves as the interleaved matrix does.
  const Csr C = component_major(A);
  auto s = make({"method=block-jacobi-pcg", "layout=component", "tol=1e-10"});
  s->setup(C);
  Vector x;
  CHECK(s->solve(Vector::Ones(C.rows()), x).status == SolveStatus::converged);
}

TEST_CASE("Solver entry points on the caller's arrays: setup and update from a view, solve on pointers",
          "[sparse][views]") {
  const Csr A = spring_lattice(4).to_csr();
  // The caller's arrays: 32-bit row pointers and columns, each row's diagonal first (unsorted).
  std::vector<std::int32_t> row_ptr{0}, cols;
  std::vector<double> vals;
  const CsrPattern& p = A.pattern();
  for (index_t i = 0; i < A.rows(); ++i) {
    cols.push_back(i);
    vals.push_back(A.values()[p.find(i, i)]);
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      if (p.col_idx[k] != i) cols.push_back(p.col_idx[k]), vals.push_back(A.values()[k]);
    row_ptr.push_back(static_cast<std::int32_t>(cols.size()));
  }
  CsrView view;
  view.rows = view.cols = A.rows();
  view.nnz = static_cast<offset_t>(vals.size());
  view.row_ptr = row_ptr.data(), view.row_ptr_bytes = 4;
  view.col_idx = cols.data(), view.col_idx_bytes = 4;
  view.values = vals.data();

  std::vector<double> b(A.rows()), x(A.rows(), 0.0);
  for (size_t i = 0; i < b.size(); ++i) b[i] = 1.0 + 0.01 * static_cast<double>(i % 17);
  auto s = make({"method=block-jacobi-pcg", "tol=1e-10"});
  s->setup(view);
  std::vector<double>().swap(vals);  // the solver keeps its own copy: the caller's arrays may go
  const SolveResult r = s->solve(b.data(), x.data());
  CHECK(r.status == SolveStatus::converged);
  const Vector xv = Eigen::Map<const Vector>(x.data(), A.rows());
  const Vector bv = Eigen::Map<const Vector>(b.data(), A.rows());
  CHECK((bv - A.to_eigen() * xv).norm() <= 1e-9 * bv.norm());

  // update() with new values on the same pattern: the answer of the doubled matrix is half.
  std::vector<double> doubled;
  for (index_t i = 0; i < A.rows(); ++i) {
    doubled.push_back(2 * A.values()[p.find(i, i)]);
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      if (p.col_idx[k] != i) doubled.push_back(2 * A.values()[k]);
  }
  view.values = doubled.data();
  s->update(view);
  std::vector<double> y(A.rows(), 0.0);
  s->solve(b.data(), y.data());
  for (index_t i = 0; i < A.rows(); ++i) CHECK(y[i] == Approx(x[i] / 2).epsilon(1e-7));

  // Refused values (negative definite) leave the kept matrix as it was: the next solve is unchanged.
  std::vector<double> negated(doubled);
  for (double& v : negated) v = -v;
  auto chol = make({"method=block-jacobi-pcg", "tol=1e-10"});
  view.values = doubled.data();
  chol->setup(view);
  view.values = negated.data();
  CHECK_THROWS(chol->update(view));
  std::vector<double> z(A.rows(), 0.0);
  chol->solve(b.data(), z.data());
  for (index_t i = 0; i < A.rows(); ++i) CHECK(z[i] == Approx(y[i]).epsilon(1e-7));
  view.values = doubled.data();

  // A different pattern, and update(view) without a set-up from a view, are named.
  CsrView shorter = view;
  shorter.nnz -= 1;
  std::vector<std::int32_t> rp = row_ptr;
  rp.back() -= 1;
  shorter.row_ptr = rp.data();
  CHECK_THROWS_WITH(s->update(shorter), Catch::Contains("pattern differs"));
  auto t = make({"method=cg"});
  t->setup(A);
  CHECK_THROWS_WITH(t->update(view), Catch::Contains("needs a set-up from a view"));
  CHECK_THROWS_AS(t->solve(static_cast<const double*>(nullptr), y.data()), InputError);
}
