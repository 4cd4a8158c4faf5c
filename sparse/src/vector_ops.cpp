#include "pmg/sparse/vector_ops.hpp"

#include <cmath>

namespace pmg::ops {

double dot(const Vector& x, const Vector& y) {
  const Eigen::Index n = x.size();
  const double* a = x.data();
  const double* b = y.data();
  double s = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : s)
  for (Eigen::Index i = 0; i < n; ++i) s += a[i] * b[i];
  return s;
}

double norm2(const Vector& x) { return std::sqrt(dot(x, x)); }

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

bool all_finite(const Vector& x) {
  // NaN and Inf propagate into the sum (Inf - Inf = NaN): one pass, no branches.
  double s = 0.0;
  const Eigen::Index n = x.size();
  const double* xp = x.data();
#pragma omp parallel for schedule(static) reduction(+ : s)
  for (Eigen::Index i = 0; i < n; ++i) s += xp[i] * 0.0;
  return std::isfinite(s) || n == 0;
}

}  // namespace pmg::ops
