#include "pmg/multigrid/smoothers.hpp"

namespace pmg::mg {

BlockJacobi::BlockJacobi(const Bcsr& A, const JacobiParams& params) : A_(A), params_(params) {
  if (!(params.omega > 0)) throw InputError("Jacobi: omega must be positive");
  update();
}

void BlockJacobi::update() { inv_diag_ = inverse_diagonal_blocks(A_); }

void BlockJacobi::smooth(const Vector& b, Vector& x) const {
  Vector r;
  const Eigen::Index nb = x.size() / 3;
  for (int s = 0; s < params_.sweeps; ++s) {
    A_.residual(b, x, r);
#pragma omp parallel for schedule(static)
    for (Eigen::Index I = 0; I < nb; ++I) {
      const double* d = inv_diag_.data() + 9 * I;
      const double r0 = r[3 * I], r1 = r[3 * I + 1], r2 = r[3 * I + 2];
      x[3 * I] += params_.omega * (d[0] * r0 + d[1] * r1 + d[2] * r2);
      x[3 * I + 1] += params_.omega * (d[3] * r0 + d[4] * r1 + d[5] * r2);
      x[3 * I + 2] += params_.omega * (d[6] * r0 + d[7] * r1 + d[8] * r2);
    }
  }
}

}  // namespace pmg::mg
