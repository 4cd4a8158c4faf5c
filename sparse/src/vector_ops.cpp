#include "pmg/sparse/vector_ops.hpp"

#include "pmg/sparse/block3.hpp"

#include <algorithm>
#include <cmath>

namespace pmg::ops {

namespace {

template <class T, class U>
double dot_lanes(const T* a, const U* b, std::ptrdiff_t n) {
  double s[8] = {};
  std::ptrdiff_t k = 0;
  for (; k + 8 <= n; k += 8)
    for (int l = 0; l < 8; ++l) s[l] += static_cast<double>(a[k + l]) * static_cast<double>(b[k + l]);
  for (int l = 0; k < n; ++k, ++l) s[l] += static_cast<double>(a[k]) * static_cast<double>(b[k]);
  return ((s[0] + s[4]) + (s[2] + s[6])) + ((s[1] + s[5]) + (s[3] + s[7]));
}

}  // namespace

double dot_serial(const double* a, const double* b, std::ptrdiff_t n) { return dot_lanes(a, b, n); }

double dot_serial(const float* a, const double* b, std::ptrdiff_t n) { return dot_lanes(a, b, n); }

namespace {
constexpr Eigen::Index kDotBlock = 8192;  // entries per block of dot(): its sums are added in order
}  // namespace

namespace {
/// xᵀy over fixed blocks of kDotBlock entries (dot_lanes each), the blocks' sums added in order.
template <class T>
double blocked_dot(const T* a, const T* b, Eigen::Index n) {
  const Eigen::Index blocks = (n + kDotBlock - 1) / kDotBlock;
  if (blocks <= 1) return dot_lanes(a, b, n);
  double local[64];
  std::vector<double> heap;
  double* part = local;
  if (blocks > 64) {
    heap.resize(static_cast<size_t>(blocks));
    part = heap.data();
  }
#pragma omp parallel for schedule(static)
  for (Eigen::Index q = 0; q < blocks; ++q) {
    const Eigen::Index k0 = q * kDotBlock;
    part[q] = dot_lanes(a + k0, b + k0, std::min(kDotBlock, n - k0));
  }
  double s = 0.0;
  for (Eigen::Index q = 0; q < blocks; ++q) s += part[q];
  return s;
}
}  // namespace

double dot(const Vector& x, const Vector& y) { return blocked_dot(x.data(), y.data(), x.size()); }

double dot(const Eigen::VectorXf& x, const Eigen::VectorXf& y) { return blocked_dot(x.data(), y.data(), x.size()); }

double norm2(const Vector& x) {
  // The fast sum of squares is exact enough while it stays in double's normal range; where it
  // underflowed (entries below about 1e-154) or overflowed (above 1e154), Eigen's scaled
  // stableNorm gives the norm any finite vector has.
  const double s = dot(x, x);
  if (s > 1e-290 && s < 1e290) return std::sqrt(s);
  return x.stableNorm();
}

void axpy(double a, const Vector& x, Vector& y) {
  const Eigen::Index n = x.size();
  const double* xp = x.data();
  double* yp = y.data();
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) yp[i] += a * xp[i];
}

void xpby(const Vector& x, double b, Vector& y) {
  const Eigen::Index n = x.size();
  const double* xp = x.data();
  double* yp = y.data();
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) yp[i] = xp[i] + b * yp[i];
}

bool all_finite(const Vector& x) { return all_finite(x.data(), x.size()); }

bool all_finite(const double* x, std::int64_t n) {
  // NaN and Inf propagate into the sum (Inf - Inf = NaN): one pass, no branches.
  double s = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : s)
  for (std::int64_t i = 0; i < n; ++i) s += x[i] * 0.0;
  return std::isfinite(s) || n == 0;
}

void block_diagonal_apply(const std::vector<double>& D, const Vector& r, Vector& z) {
  z.resize(r.size());
  block_diagonal_apply(D.data(), r.data(), z.data(), static_cast<index_t>(r.size() / 3));
}

void block_diagonal_apply(const double* D, const double* r, double* z, index_t blocks) {
  const std::ptrdiff_t nb = blocks;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t I = 0; I < nb; ++I) block3_apply(D + 9 * I, r + 3 * I, z + 3 * I);
}

void block_diagonal_apply(const float* D, const float* r, float* z, index_t blocks) {
  const std::ptrdiff_t nb = blocks;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t I = 0; I < nb; ++I) block3_apply(D + 9 * I, r + 3 * I, z + 3 * I);
}

namespace {
template <class T>
double update_dot(double a, const T* wp, const T* d, T* rp, T* zp, Eigen::Index n) {
  constexpr Eigen::Index kBlock = 3 * 2730;  // entries per block of the sum: whole 3x3 blocks
  const T c = static_cast<T>(a);
  const Eigen::Index blocks = (n + kBlock - 1) / kBlock;
  std::vector<double> part(static_cast<size_t>(blocks));
#pragma omp parallel for schedule(static) if (blocks > 1)
  for (Eigen::Index q = 0; q < blocks; ++q) {
    const Eigen::Index k0 = q * kBlock, k1 = std::min(n, k0 + kBlock);
    if (a != 0.0)
      for (Eigen::Index k = k0; k < k1; ++k) rp[k] += c * wp[k];
    for (Eigen::Index I = k0 / 3; I < k1 / 3; ++I) block3_apply(d + 9 * I, rp + 3 * I, zp + 3 * I);
    part[static_cast<size_t>(q)] = dot_lanes(rp + k0, zp + k0, k1 - k0);
  }
  double s = 0.0;
  for (double v : part) s += v;
  return s;
}
}  // namespace

double block_diagonal_update_dot(double a, const Vector& w, const std::vector<double>& D, Vector& r, Vector& z) {
  z.resize(r.size());
  return update_dot(a, w.data(), D.data(), r.data(), z.data(), r.size());
}

double block_diagonal_update_dot(double a, const Eigen::VectorXf& w, const std::vector<float>& D, Eigen::VectorXf& r,
                                 Eigen::VectorXf& z) {
  z.resize(r.size());
  return update_dot(a, w.data(), D.data(), r.data(), z.data(), r.size());
}

void xpby(const Eigen::VectorXf& x, double b, Eigen::VectorXf& y) {
  const Eigen::Index n = x.size();
  const float c = static_cast<float>(b);
  const float* xp = x.data();
  float* yp = y.data();
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) yp[i] = xp[i] + c * yp[i];
}

void block_diagonal_axpy(double a, const std::vector<double>& D, const Vector& r, Vector& x) {
  const Eigen::Index nb = r.size() / 3;
  const double* d = D.data();
  const double* rp = r.data();
  double* xp = x.data();
#pragma omp parallel for schedule(static)
  for (Eigen::Index I = 0; I < nb; ++I) {
    double z[3];
    block3_apply(d + 9 * I, rp + 3 * I, z);
    for (int c = 0; c < 3; ++c) xp[3 * I + c] += a * z[c];
  }
}

}  // namespace pmg::ops
