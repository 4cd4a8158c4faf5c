#include "pmg/multigrid/chebyshev.hpp"

#include <cmath>

namespace pmg::mg {

Chebyshev::Chebyshev(const ChebyshevParams& params) : params_(params) {
  if (params.degree < 1) throw InputError("Chebyshev: degree must be >= 1");
  if (!(params.lower_fraction > 0 && params.lower_fraction < 1))
    throw InputError("Chebyshev: lower_fraction must lie in (0, 1)");
  if (params.power_iterations < 1) throw InputError("Chebyshev: power_iterations must be >= 1");
}

void Chebyshev::setup_impl(const LinearOperator& A) {
  A_ = &A;
  const Eigen::Index n = A.rows();
  r_.resize(n), d_.resize(n), z_.resize(n);
  inv_diag_ = inverse_diagonal_blocks(*A_);
  estimate(params_.power_iterations, false);
}

void Chebyshev::apply_inverse_diagonal(const Vector& r, Vector& z) const {
  const Eigen::Index nb = r.size() / 3;
  z.resize(r.size());
#pragma omp parallel for schedule(static)
  for (Eigen::Index I = 0; I < nb; ++I) {
    const double* d = inv_diag_.data() + 9 * I;
    const double r0 = r[3 * I], r1 = r[3 * I + 1], r2 = r[3 * I + 2];
    z[3 * I] = d[0] * r0 + d[1] * r1 + d[2] * r2;
    z[3 * I + 1] = d[3] * r0 + d[4] * r1 + d[5] * r2;
    z[3 * I + 2] = d[6] * r0 + d[7] * r1 + d[8] * r2;
  }
}

void Chebyshev::update_impl() {
  inv_diag_ = inverse_diagonal_blocks(*A_);
  if (params_.update_iterations > 0) estimate(params_.update_iterations, true);
  else estimate(params_.power_iterations, false);
}

void Chebyshev::estimate(int iterations, bool warm) {
  // Power iteration on D⁻¹A from a fixed, non-smooth start vector or the last estimate's (in
  // work vectors kept from set-up: an update per time step allocates nothing).
  Vector &v = eigenvector_, &w = r_, &z = z_;
  if (!warm || v.size() != z.size()) {
    v.resize(z.size());
    for (Eigen::Index i = 0; i < v.size(); ++i) v[i] = 1.0 + 0.5 * std::sin(0.7 * i);
    v.normalize();
  }
  double lambda = 0.0;
  for (int k = 0; k < iterations; ++k) {
    A_->apply(v, w);
    apply_inverse_diagonal(w, z);
    lambda = z.norm();
    if (!(lambda > 0) || !std::isfinite(lambda)) throw InputError("Chebyshev: D^-1 A has no positive spectrum estimate");
    v = z / lambda;
  }
  lambda_max_ = 1.1 * lambda;
}

// Chebyshev iteration for D⁻¹A on [λmin, λmax], x improved in place.
void Chebyshev::smooth(const Vector& b, Vector& x) const {
  const double lmax = lambda_max_, lmin = params_.lower_fraction * lambda_max_;
  const double theta = 0.5 * (lmax + lmin), delta = 0.5 * (lmax - lmin);
  const double sigma = theta / delta;
  double rho = 1.0 / sigma;
  A_->residual(b, x, r_);
  apply_inverse_diagonal(r_, d_);
  d_ /= theta;
  for (int k = 1; k <= params_.degree; ++k) {
    x += d_;
    if (k == params_.degree) break;
    A_->residual(b, x, r_);
    apply_inverse_diagonal(r_, z_);
    const double rho_new = 1.0 / (2.0 * sigma - rho);
    d_ = (rho_new * rho) * d_ + (2.0 * rho_new / delta) * z_;
    rho = rho_new;
  }
}

}  // namespace pmg::mg
