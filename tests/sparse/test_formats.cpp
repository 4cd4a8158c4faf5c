#include "fixture.hpp"

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
}

TEST_CASE("every format builds the same matrix and its SpMV matches the dense reference",
          "[sparse][spmv]") {
  const auto blocks = irregular_blocks();
  const index_t n = 23;
  const Eigen::MatrixXd D = dense_from_blocks(n, blocks);
  const Bcsr bcsr = Bcsr::from_block_triplets(n, n, blocks);
  const Csr csr = csr_from_dense(D);
  const Bcsr bcsr_from_csr = Bcsr::from_csr(csr);
  const BinBcsr bin(bcsr);
  const Csr csr_from_bcsr = bcsr.to_csr();

  REQUIRE(Eigen::MatrixXd(csr.to_eigen()) == D);
  REQUIRE(Eigen::MatrixXd(csr_from_bcsr.to_eigen()) == D);
  CHECK(bcsr_from_csr.num_blocks() == bcsr.num_blocks());
  CHECK(bin.num_bins() == 3);

  for (unsigned seed = 1; seed <= 3; ++seed) {
    const Vector x = random_vector(3 * n, seed);
    const Vector ref = D * x;
    const Vector b = random_vector(3 * n, seed + 10);
    for (const LinearOperator* op :
         {static_cast<const LinearOperator*>(&csr), static_cast<const LinearOperator*>(&bcsr),
          static_cast<const LinearOperator*>(&bcsr_from_csr),
          static_cast<const LinearOperator*>(&bin),
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

TEST_CASE("BIN-BCSR stores bins column-major with the diagonal apart", "[sparse][bin]") {
  const auto blocks = irregular_blocks();
  const index_t n = 23;
  const Bcsr A = Bcsr::from_block_triplets(n, n, blocks);
  const BinBcsr bin(A);
  const auto& p = A.pattern();
  constexpr int W = BinBcsr::kBinRows;
  for (index_t row = 0; row < 3 * n; ++row) {
    const index_t b = row / W, r = row % W, I = row / 3, i = row % 3;
    const index_t nbr = bin.bin_block_rows()[b];
    const index_t l = I - bin.first_block_row()[b];
    REQUIRE(l >= 0);
    REQUIRE(l < nbr);
    index_t k = 0;
    for (offset_t s = p.row_ptr[I]; s < p.row_ptr[I + 1]; ++s) {
      if (p.col_idx[s] == I) {
        for (int c = 0; c < 3; ++c)
          CHECK(bin.diagonal_blocks()[9 * I + 3 * i + c] == A.block(s)(i, c));
        continue;
      }
      CHECK(bin.columns()[bin.col_offset()[b] + k * nbr + l] == p.col_idx[s]);
      for (int c = 0; c < 3; ++c)
        CHECK(bin.values()[bin.val_offset()[b] + (3 * k + c) * W + r] == A.block(s)(i, c));
      ++k;
    }
    for (; k < bin.width()[b]; ++k) {  // padding
      CHECK(bin.columns()[bin.col_offset()[b] + k * nbr + l] == -1);
      for (int c = 0; c < 3; ++c)
        CHECK(bin.values()[bin.val_offset()[b] + (3 * k + c) * W + r] == 0.0);
    }
  }
  // Block row 5 has no diagonal block: its diagonal is stored as zeros.
  for (int e = 0; e < 9; ++e) CHECK(bin.diagonal_blocks()[9 * 5 + e] == 0.0);
  CHECK(bin.padding_ratio() >= 1.0);
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
