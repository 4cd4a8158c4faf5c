#include "fixture.hpp"

#include "pmg/sparse/csr_view.hpp"
#include "pmg/sparse/generators.hpp"

#include <catch2/catch.hpp>

using namespace pmg;
using namespace pmg::test;

TEST_CASE("CSR from triplets sums duplicates and matches the dense reference", "[sparse][csr]") {
  std::vector<Triplet> t{{0, 0, 1.0}, {0, 0, 2.0}, {1, 2, -1.0}, {2, 1, 4.0}, {2, 2, 5.0}};
  const Csr A = Csr::from_triplets(3, 3, t);
  CHECK(A.nnz() == 4);
  Eigen::MatrixXd D(3, 3);
  D << 3, 0, 0, 0, 0, -1, 0, 4, 5;
  CHECK(Eigen::MatrixXd(A.to_eigen()) == D);
  CHECK_THROWS_AS(Csr::from_triplets(3, 3, {{3, 0, 1.0}}), InputError);
}

TEST_CASE("CSR transposed keeps every entry, explicit zeros included, and equals Eigen's transpose",
          "[sparse][csr]") {
  // 4 x 6: an empty row (2), empty columns (1, 5), an explicit zero at (3, 0).
  const Csr A = Csr::from_triplets(4, 6, {{0, 0, 1.0}, {0, 3, 2.0}, {1, 2, -3.0}, {1, 4, 4.0},
                                          {3, 0, 0.0}, {3, 2, 5.0}, {3, 4, 6.0}});
  const Csr T = A.transposed();
  REQUIRE(T.rows() == 6);
  REQUIRE(T.cols() == 4);
  CHECK(T.nnz() == A.nnz());  // the explicit zero stays
  T.pattern().validate();     // sorted, unique columns per row
  CHECK(Eigen::MatrixXd(T.to_eigen()) == Eigen::MatrixXd(A.to_eigen()).transpose());
  CHECK(T.pattern().find(0, 3) >= 0);
  CHECK(T.transposed().pattern().col_idx == A.pattern().col_idx);
  CHECK(T.transposed().values() == A.values());
  const Csr lattice = spring_lattice(4).to_csr();
  CHECK(Eigen::MatrixXd(lattice.transposed().to_eigen()) == Eigen::MatrixXd(lattice.to_eigen()).transpose());
}

TEST_CASE("CSR pattern validation names what is wrong", "[sparse][csr]") {
  auto p = std::make_shared<CsrPattern>();
  p->rows = 2;
  p->cols = 2;
  p->row_ptr = {0, 2, 3};
  p->col_idx = {1, 0, 1};  // row 0 unsorted
  CHECK_THROWS_WITH(Csr(p, {1, 2, 3}), Catch::Contains("not sorted"));
  p->col_idx = {0, 1, 2};  // column out of range
  CHECK_THROWS_WITH(Csr(p, {1, 2, 3}), Catch::Contains("out of range"));
  p->col_idx = {0, 1, 1};
  CHECK_THROWS_WITH(Csr(p, {1, 2}), Catch::Contains("2 values"));
  // A view whose row pointers rise past the arrays and fall back: refused before any entry is read.
  const std::vector<std::int32_t> ptr{0, 2000000000, 2}, col{0, 1};
  const std::vector<double> val{1.0, 2.0};
  CsrView v;
  v.rows = 2, v.cols = 2, v.nnz = 2;
  v.row_ptr = ptr.data(), v.row_ptr_bytes = 4, v.col_idx = col.data(), v.col_idx_bytes = 4, v.values = val.data();
  CHECK_THROWS_WITH(v.validate("view", false), Catch::Contains("row pointers decrease at row 1"));
}

TEST_CASE("every format builds the same matrix and its SpMV matches the dense reference",
          "[sparse][spmv]") {
  const auto blocks = irregular_blocks();
  const index_t n = 23;
  const Eigen::MatrixXd D = dense_from_blocks(n, blocks);
  const Bcsr bcsr = Bcsr::from_block_triplets(n, n, blocks);
  const Csr csr = csr_from_dense(D);
  const Bcsr bcsr_from_csr = Bcsr::from_csr(csr);
  const Csr csr_from_bcsr = bcsr.to_csr();

  REQUIRE(Eigen::MatrixXd(csr.to_eigen()) == D);
  REQUIRE(Eigen::MatrixXd(csr_from_bcsr.to_eigen()) == D);
  CHECK(bcsr_from_csr.num_blocks() == bcsr.num_blocks());

  for (unsigned seed = 1; seed <= 3; ++seed) {
    const Vector x = random_vector(3 * n, seed);
    const Vector ref = D * x;
    const Vector b = random_vector(3 * n, seed + 10);
    for (const LinearOperator* op :
         {static_cast<const LinearOperator*>(&csr), static_cast<const LinearOperator*>(&bcsr),
          static_cast<const LinearOperator*>(&bcsr_from_csr),
          static_cast<const LinearOperator*>(&csr_from_bcsr)}) {
      Vector y, r;
      op->apply(x, y);
      CHECK(rel_diff(y, ref) < 1e-14);
      op->residual(b, x, r);
      CHECK(rel_diff(r, Vector(b - ref)) < 1e-14);
    }
  }
}

TEST_CASE("fused apply_dot returns A x and x.(A x)", "[sparse][spmv]") {
  const Bcsr A = spring_lattice(5);
  const Vector x = random_vector(A.rows(), 3);
  const Vector ref = A.to_csr().to_eigen() * x;
  const Csr C = A.to_csr();
  for (const LinearOperator* op :
       {static_cast<const LinearOperator*>(&A), static_cast<const LinearOperator*>(&C)}) {
    Vector y;
    const double d = op->apply_dot(x, y);
    CHECK(rel_diff(y, ref) < 1e-14);
    CHECK(d == Approx(x.dot(ref)).epsilon(1e-13));
  }
}

namespace {
// Every BIN-BCSR layout the tests sweep: lanes × sorting windows (1: unsorted, 0: automatic).
std::vector<BinBcsrOptions> bin_layouts() {
  std::vector<BinBcsrOptions> o;
  for (int lanes : {1, 2, 4, 8, 32})
    for (index_t window : {1, 5, 0}) o.push_back({lanes, window});
  o.push_back({});  // both automatic
  return o;
}
}  // namespace

TEST_CASE("BIN-BCSR layout: sorted slots, lane-major blocks, padding last, diagonal apart",
          "[sparse][bin]") {
  const auto blocks = irregular_blocks();
  const index_t n = 23;
  const Bcsr A = Bcsr::from_block_triplets(n, n, blocks);
  const auto& p = A.pattern();
  constexpr int W = BinBcsr::kBinLanes;
  auto off_diagonal = [&](index_t I) {
    index_t k = 0;
    for (offset_t s = p.row_ptr[I]; s < p.row_ptr[I + 1]; ++s) k += p.col_idx[s] != I;
    return k;
  };
  for (const BinBcsrOptions& o : bin_layouts()) {
    const BinBcsr bin(A, o);
    const int L = bin.lanes();
    const index_t R = W / L;
    INFO("lanes " << L << ", window " << bin.sort_window());
    if (o.lanes != 0) CHECK(L == o.lanes);
    // Windows hold whole bins (an explicit window is rounded up), or are single rows.
    if (o.sort_window == 1) CHECK(bin.sort_window() == 1);
    else CHECK((bin.sort_window() % R == 0 || bin.sort_window() >= n));
    if (o.sort_window > 1) CHECK(bin.sort_window() >= std::min<index_t>(o.sort_window, n));
    REQUIRE(bin.num_bins() == (n + R - 1) / R);
    // The permutation: every block row once, unused slots only at the end, longest rows first
    // within each window, original order among equals.
    const auto& perm = bin.permutation();
    REQUIRE(perm.size() == static_cast<std::size_t>(bin.num_bins() * R));
    std::vector<int> seen(n, 0);
    for (std::size_t s = 0; s < perm.size(); ++s) {
      if (s >= static_cast<std::size_t>(n)) {
        CHECK(perm[s] == -1);
        continue;
      }
      REQUIRE(perm[s] >= 0);
      REQUIRE(perm[s] < n);
      ++seen[perm[s]];
      CHECK(perm[s] / bin.sort_window() == static_cast<index_t>(s) / bin.sort_window());
      if (s % bin.sort_window() != 0) {
        const index_t a = perm[s - 1], b = perm[s];
        CHECK(off_diagonal(a) >= off_diagonal(b));
        if (off_diagonal(a) == off_diagonal(b)) CHECK(a < b);
      }
    }
    CHECK(std::all_of(seen.begin(), seen.end(), [](int c) { return c == 1; }));
    // Blocks: the k-th off-diagonal block of the row in slot r of bin b is at lane L r + k mod L,
    // step k / L; the rest of a bin's width is padding (column -1, zero values).
    for (index_t slot = 0; slot < n; ++slot) {
      const index_t I = perm[slot], b = slot / R, r = slot % R;
      std::vector<int> steps(L, 0);
      index_t k = 0;
      for (offset_t s = p.row_ptr[I]; s < p.row_ptr[I + 1]; ++s) {
        if (p.col_idx[s] == I) {
          for (int e = 0; e < 9; ++e) CHECK(bin.diagonal_blocks()[9 * I + e] == A.block(s).data()[e] );
          continue;
        }
        const index_t lane = L * r + k % L, step = k / L;
        REQUIRE(step < bin.width()[b]);
        const std::int64_t q = bin.offset()[b] + W * step + lane;
        CHECK(bin.columns()[q] == p.col_idx[s]);
        for (int i = 0; i < 3; ++i)
          for (int c = 0; c < 3; ++c)
            CHECK(bin.values()[9 * bin.offset()[b] + 9 * W * step + (3 * i + c) * W + lane] == A.block(s)(i, c));
        ++steps[k % L];
        ++k;
      }
      for (int t = 0; t < L; ++t)
        for (index_t step = steps[t]; step < bin.width()[b]; ++step) {
          const std::int64_t q = bin.offset()[b] + W * step + L * r + t;
          CHECK(bin.columns()[q] == -1);
          for (int e = 0; e < 9; ++e) CHECK(bin.values()[9 * bin.offset()[b] + 9 * W * step + e * W + L * r + t] == 0.0);
        }
      CHECK(bin.width()[b] >= (k + L - 1) / L);
    }
    // Block row 5 has no diagonal block: its diagonal is stored as zeros.
    for (int e = 0; e < 9; ++e) CHECK(bin.diagonal_blocks()[9 * 5 + e] == 0.0);
    CHECK(bin.padding_ratio() >= 1.0);
    // The byte count is the arrays' sizes: values and diagonal (8 B), columns and permutation (4 B),
    // width and offset per bin (12 B), x and y.
    CHECK(bin.bytes_per_spmv() == 8.0 * (bin.values().size() + bin.diagonal_blocks().size()) +
                                      4.0 * (bin.columns().size() + bin.permutation().size()) +
                                      12.0 * bin.num_bins() + 16.0 * A.rows());
  }
}

TEST_CASE("BIN-BCSR SpMV and residual match the dense reference in every layout", "[sparse][bin][spmv]") {
  const auto blocks = irregular_blocks();
  const index_t n = 23;
  const Eigen::MatrixXd D = dense_from_blocks(n, blocks);
  const Bcsr small = Bcsr::from_block_triplets(n, n, blocks);
  const Bcsr lattice = spring_lattice(6);  // 216 block rows: many bins and windows
  const Eigen::MatrixXd DL(lattice.to_csr().to_eigen());
  for (const BinBcsrOptions& o : bin_layouts())
    for (const auto& [A, dense] : {std::pair{&small, &D}, std::pair{&lattice, &DL}}) {
      const BinBcsr bin(*A, o);
      INFO("lanes " << bin.lanes() << ", window " << bin.sort_window() << ", rows " << A->rows());
      const Vector x = random_vector(A->cols(), 11), b = random_vector(A->rows(), 12);
      const Vector ref = *dense * x;
      Vector y, r;
      bin.apply(x, y);
      CHECK(rel_diff(y, ref) < 1e-14);
      bin.residual(b, x, r);
      CHECK(rel_diff(r, Vector(b - ref)) < 1e-14);
    }
}

TEST_CASE("BIN-BCSR options out of range are refused", "[sparse][bin]") {
  const Bcsr A = Bcsr::from_block_triplets(23, 23, irregular_blocks());
  CHECK_THROWS_WITH(BinBcsr().update_values(A), Catch::Contains("nothing was sliced"));
  // The layout hash tells layouts apart, and repeats for the same slicing.
  CHECK(BinBcsr(A, {4, 1}).layout_hash() == BinBcsr(A, {4, 1}).layout_hash());
  CHECK(BinBcsr(A, {4, 1}).layout_hash() != BinBcsr(A, {4, 0}).layout_hash());
  CHECK(BinBcsr(A, {4, 1}).layout_hash() != BinBcsr(A, {2, 1}).layout_hash());
  for (int lanes : {-1, 3, 6, 64})
    CHECK_THROWS_WITH(BinBcsr(A, {lanes, 0}), Catch::Contains("lanes must be"));
  CHECK_THROWS_WITH(BinBcsr(A, {1, -2}), Catch::Contains("sort_window"));
  const Bcsr rect = Bcsr::from_block_triplets(2, 3, {{0, 2, Block3::Identity()}});
  CHECK_THROWS_WITH(BinBcsr(rect), Catch::Contains("square"));
}

TEST_CASE("BIN-BCSR sorting and lanes keep its bytes within 1.1x BCSR on a lattice", "[sparse][bin]") {
  // The 27-point lattice has rows of 7 to 26 off-diagonal blocks; unsorted bins pad boundary rows
  // to interior ones. Sorted, a bin's rows have nearly equal lengths.
  const Bcsr A = spring_lattice(12);
  const BinBcsr unsorted(A, {1, 1}), sorted(A);
  INFO("lanes " << sorted.lanes() << ": bytes " << sorted.bytes_per_spmv() / A.bytes_per_spmv()
                << "x BCSR, unsorted " << unsorted.bytes_per_spmv() / A.bytes_per_spmv() << "x");
  CHECK(sorted.bytes_per_spmv() <= 1.1 * A.bytes_per_spmv());
  CHECK(sorted.padding_ratio() < unsorted.padding_ratio());
  CHECK(BinBcsr::auto_lanes(A.pattern()) == sorted.lanes());
  CHECK(sorted.lanes() == 2);  // mean 21.8 off-diagonal blocks per row: 10.9 steps at 2 lanes
}

TEST_CASE("values update in place on a fixed pattern in every format", "[sparse][pattern]") {
  const auto blocks = irregular_blocks();
  const index_t n = 23;
  Bcsr A = Bcsr::from_block_triplets(n, n, blocks);
  BinBcsr bin(A);
  Csr csr = A.to_csr();
  const double* bcsr_data = A.values().data();
  const double* bin_data = bin.values().data();
  const double* csr_data = csr.values().data();

  auto blocks2 = irregular_blocks(99);  // same pattern, new values
  const Eigen::MatrixXd D2 = dense_from_blocks(n, blocks2);
  A.set_values(csr_from_dense(D2));
  bin.update_values(A);
  csr.set_values(A.to_csr());
  CHECK(A.values().data() == bcsr_data);
  CHECK(bin.values().data() == bin_data);
  CHECK(csr.values().data() == csr_data);
  const Vector x = random_vector(3 * n, 5);
  const Vector ref = D2 * x;
  Vector y;
  for (const LinearOperator* op : {static_cast<const LinearOperator*>(&A),
                                   static_cast<const LinearOperator*>(&bin),
                                   static_cast<const LinearOperator*>(&csr)}) {
    op->apply(x, y);
    CHECK(rel_diff(y, ref) < 1e-14);
  }

  SECTION("an entry outside the pattern is refused") {
    const Csr outside = Csr::from_triplets(3 * n, 3 * n, {{0, 3 * 7, 1.0}});
    CHECK_THROWS_WITH(A.set_values(outside), Catch::Contains("outside the stored blocks"));
    CHECK_THROWS_WITH(csr.set_values(outside), Catch::Contains("not in the pattern"));
  }
  SECTION("BIN-BCSR refuses a matrix with another pattern") {
    const Bcsr other = spring_lattice(3);
    CHECK_THROWS_AS(bin.update_values(other), InputError);
  }
}

TEST_CASE("BCSR assembly map: find_block gives the slot to write a block into", "[sparse][pattern]") {
  Bcsr A = spring_lattice(3);
  const offset_t k = A.find_block(4, 5);
  REQUIRE(k >= 0);
  CHECK(A.find_block(0, 26) == -1);  // opposite corners are not neighbours
  A.block(k) = Block3::Constant(2.0);
  CHECK(A.to_csr().to_eigen().coeff(12, 15) == 2.0);
}

TEST_CASE("operators refuse vectors of the wrong size", "[sparse][operator]") {
  const Bcsr A = spring_lattice(3);
  Vector y;
  CHECK_THROWS_WITH(A.apply(Vector::Zero(5), y), Catch::Contains("5 entries"));
  CHECK_THROWS_AS(Bcsr::from_csr(Csr::from_triplets(4, 4, {})), InputError);
}

TEST_CASE("spring lattice is symmetric with a 27-point block stencil", "[sparse][generators]") {
  const Bcsr A = spring_lattice(4);
  CHECK(A.block_rows() == 64);
  CHECK(A.to_csr().is_symmetric(1e-14));
  index_t longest = 0;
  for (index_t I = 0; I < A.block_rows(); ++I)
    longest = std::max<index_t>(longest, A.pattern().row_ptr[I + 1] - A.pattern().row_ptr[I]);
  CHECK(longest == 27);
  const Eigen::MatrixXd D = A.to_csr().to_eigen();
  CHECK(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(D).eigenvalues().minCoeff() > 0.0);
}
