#include "pmg/multigrid/smoothers.hpp"

namespace pmg::mg {

BlockJacobi::BlockJacobi(const JacobiParams& params) : params_(params) {
  if (!(params.omega > 0)) throw InputError("Jacobi: omega must be positive");
  if (params.sweeps < 0) throw InputError("Jacobi: sweeps must be >= 0");
}

void BlockJacobi::setup_impl(const LinearOperator& A) {
  inv_diag_ = inverse_diagonal_blocks(A);
  r_.resize(A.rows());
}

void BlockJacobi::update_impl() { inv_diag_ = inverse_diagonal_blocks(system()); }

void BlockJacobi::smooth(const Vector& b, Vector& x) const {
  const LinearOperator& A = system();
  const Eigen::Index nb = x.size() / 3;
  for (int s = 0; s < params_.sweeps; ++s) {
    A.residual(b, x, r_);
#pragma omp parallel for schedule(static)
    for (Eigen::Index I = 0; I < nb; ++I) {
      const double* d = inv_diag_.data() + 9 * I;
      const double r0 = r_[3 * I], r1 = r_[3 * I + 1], r2 = r_[3 * I + 2];
      x[3 * I] += params_.omega * (d[0] * r0 + d[1] * r1 + d[2] * r2);
      x[3 * I + 1] += params_.omega * (d[3] * r0 + d[4] * r1 + d[5] * r2);
      x[3 * I + 2] += params_.omega * (d[6] * r0 + d[7] * r1 + d[8] * r2);
    }
  }
}

Richardson::Richardson(std::unique_ptr<Solver> M, const RichardsonParams& params)
    : M_(std::move(M)), params_(params) {
  if (!M_) throw InputError("Richardson: no preconditioner");
  if (params.iterations < 0) throw InputError("Richardson: iterations must be >= 0");
  if (!(params.omega > 0)) throw InputError("Richardson: omega must be positive");
}

void Richardson::setup_impl(const LinearOperator& A) {
  M_->setup(A);
  r_.resize(A.rows()), z_.resize(A.rows());
}

void Richardson::smooth(const Vector& b, Vector& x) const {
  const LinearOperator& A = system();
  for (int k = 0; k < params_.iterations; ++k) {
    A.residual(b, x, r_);
    M_->apply(r_, z_);
    x += params_.omega * z_;
  }
}

}  // namespace pmg::mg
