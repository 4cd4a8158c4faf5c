// The same small 3x3-block matrices, built once and handed to every format, plus the dense
// reference every kernel is checked against.
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/csr.hpp"

#include <Eigen/Dense>

#include <random>
#include <vector>

namespace pmg::test {

/// A non-symmetric block matrix with an irregular pattern chosen to exercise every layout corner:
/// 23 block rows = 69 scalar rows (three bins of 32, block rows straddling bin boundaries), rows of
/// different lengths, block row 5 without a diagonal block, block row 11 empty, and blocks that are
/// partly zero.
inline std::vector<BlockTriplet> irregular_blocks(unsigned seed = 7) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const index_t n = 23;
  std::vector<BlockTriplet> t;
  for (index_t I = 0; I < n; ++I) {
    if (I == 11) continue;
    for (index_t J = 0; J < n; ++J) {
      const bool diag = I == J && I != 5;
      const bool off = I != J && ((I * 7 + J * 3) % 5 == 0 || std::abs(I - J) == 1 || (I == 2 && J > 15));
      if (!diag && !off) continue;
      Block3 b;
      for (int e = 0; e < 9; ++e) b.data()[e] = u(gen);
      if ((I + J) % 4 == 0) b(0, 2) = b(2, 1) = 0.0;
      t.push_back({I, J, b});
    }
  }
  return t;
}

inline Eigen::MatrixXd dense_from_blocks(index_t n, const std::vector<BlockTriplet>& t) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (const auto& b : t) A.block<3, 3>(3 * b.row, 3 * b.col) += b.value;
  return A;
}

inline Csr csr_from_dense(const Eigen::MatrixXd& A) {
  std::vector<Triplet> t;
  for (Eigen::Index i = 0; i < A.rows(); ++i)
    for (Eigen::Index j = 0; j < A.cols(); ++j)
      if (A(i, j) != 0.0) t.emplace_back(i, j, A(i, j));
  return Csr::from_triplets(A.rows(), A.cols(), t);
}

inline Vector random_vector(Eigen::Index n, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector x(n);
  for (auto& v : x) v = u(gen);
  return x;
}

/// max |a - b| / max |b|
inline double rel_diff(const Vector& a, const Vector& b) {
  return (a - b).lpNorm<Eigen::Infinity>() / std::max(1e-300, b.lpNorm<Eigen::Infinity>());
}

}  // namespace pmg::test
