#include "pmg/sparse/generators.hpp"

#include <cmath>

namespace pmg {

Bcsr spring_lattice(index_t n) {
  if (n < 2) throw InputError("spring_lattice: n must be at least 2");
  const auto node = [n](index_t i, index_t j, index_t k) { return (k * n + j) * n + i; };
  const index_t nn = n * n * n;
  std::vector<BlockTriplet> t;
  t.reserve(static_cast<size_t>(nn) * 27);
  for (index_t k = 0; k < n; ++k)
    for (index_t j = 0; j < n; ++j)
      for (index_t i = 0; i < n; ++i) {
        const index_t a = node(i, j, k);
        Block3 diag = k == 0 ? Block3::Identity().eval() : Block3::Zero().eval();
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              const index_t ii = i + di, jj = j + dj, kk = k + dk;
              if ((di | dj | dk) == 0 || ii < 0 || jj < 0 || kk < 0 || ii >= n || jj >= n ||
                  kk >= n)
                continue;
              const Eigen::Vector3d e(di, dj, dk);
              const Eigen::Vector3d d = e.normalized();
              const Block3 S = (d * d.transpose() + 0.2 * Eigen::Matrix3d::Identity()) / e.norm();
              diag += S;
              t.push_back({a, node(ii, jj, kk), -S});
            }
        t.push_back({a, a, diag});
      }
  return Bcsr::from_block_triplets(nn, nn, t);
}

Vector smooth_field(index_t n) {
  Vector x(3 * static_cast<Eigen::Index>(n) * n * n);
  const double h = 1.0 / (n - 1);
  for (index_t k = 0; k < n; ++k)
    for (index_t j = 0; j < n; ++j)
      for (index_t i = 0; i < n; ++i) {
        const Eigen::Index a = (static_cast<Eigen::Index>(k) * n + j) * n + i;
        const double X = i * h, Y = j * h, Z = k * h;
        x[3 * a] = std::sin(M_PI * X) * Z;
        x[3 * a + 1] = std::cos(M_PI * Y) * Z * Z;
        x[3 * a + 2] = X * Y + Z;
      }
  return x;
}

}  // namespace pmg
