#include "pmg/sparse/convergence.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/block3.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <limits>

namespace pmg {

namespace {

struct Step2Sums {
  double rz = 0.0;  ///< r^T z
  double rr = 0.0;  ///< r^T r
};

// Step 2, one pass over 3-row blocks: x += alpha s; r -= alpha q; z = D^{-1} r; sums r.z and r.r.
// Reads x, s, r, q (4n) and D^{-1} (3n); writes x, r, z (3n).
Step2Sums update_and_precondition(double alpha, const Vector& s, const Vector& q,
                                  const std::vector<double>& inv_blocks, Vector& x, Vector& r,
                                  Vector& z) {
  const Eigen::Index nb = x.size() / 3;
  const double* D = inv_blocks.data();
  double rz = 0.0, rr = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : rz, rr)
  for (Eigen::Index I = 0; I < nb; ++I) {
    double ri[3];
    for (int c = 0; c < 3; ++c) {
      const Eigen::Index i = 3 * I + c;
      x[i] += alpha * s[i];
      ri[c] = r[i] - alpha * q[i];
      r[i] = ri[c];
    }
    double zi[3];
    block3_apply(D + 9 * I, ri, zi);
    for (int c = 0; c < 3; ++c) {
      z[3 * I + c] = zi[c];
      rz += ri[c] * zi[c];
      rr += ri[c] * ri[c];
    }
  }
  return {rz, rr};
}

}  // namespace

SolveResult mcg(const LinearOperator& A, const BlockJacobiPreconditioner& M, const Vector& b,
                Vector& x, const KrylovParams& params, SolveMonitor* monitor,
                KrylovWorkspace* work) {
  if (A.rows() != A.cols() || A.rows() % 3 != 0)
    throw InputError("MCG: operator must be square with a size divisible by 3");
  if (b.size() != A.rows() || M.rows() != A.rows())
    throw InputError("MCG: sizes of operator, preconditioner and right-hand side differ");
  if (x.size() != b.size()) x = Vector::Zero(b.size());
  if (!ops::all_finite(b) || !ops::all_finite(x))
    throw InputError("MCG: right-hand side or initial guess has NaN/Inf");
  detail::ConvergenceTracker track("MCG", params, monitor);
  const Eigen::Index n = b.size();
  KrylovWorkspace local;
  KrylovWorkspace& w = work ? *work : local;
  w.r.resize(n), w.z.resize(n), w.p.resize(n), w.q.resize(n);
  Vector &r = w.r, &z = w.z, &s = w.p, &q = w.q;
  A.residual(b, x, r);
  if (!track.start(ops::norm2(r), ops::norm2(b))) return track.finish(ops::norm2(r));

  double rho = 0.0;
  auto restart = [&](int it) {
    M.apply(r, z);
    s = z;
    rho = ops::dot(r, z);
    return track.check_positive(rho, "r^T M^{-1} r", it);
  };
  if (!restart(0)) return track.finish(ops::norm2(r));
  for (int it = 1; !track.done(); ++it) {
    // (1) q = A s, sigma = s^T q
    const double sigma = A.apply_dot(s, q);
    if (!track.check_positive(sigma, "s^T A s", it)) break;
    // (2) alpha = rho/sigma; x, r, z updated and r.z, r.r reduced in one pass
    const Step2Sums sums = update_and_precondition(rho / sigma, s, q, M.inverse_blocks(), x, r, z);
    track.add_energy_decrease(rho / sigma * rho);
    // The GPU reads rr back only every check_every iterations; the history still gets every one.
    const bool test = it % params.check_every == 0 || it >= params.max_iterations;
    const bool converged = track.after_iteration(it, std::sqrt(sums.rr)) && test;
    if (converged) {
      A.residual(b, x, r);
      if (track.accept_true_residual(ops::norm2(r))) break;
      if (!restart(it)) break;
      continue;
    }
    if (track.done()) break;
    if (!track.check_positive(sums.rz, "r^T M^{-1} r", it)) break;
    // (3) beta = rho'/rho; s = z + beta s
    ops::xpby(z, sums.rz / rho, s);
    rho = sums.rz;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  A.residual(b, x, q);
  return track.finish(ops::norm2(q));
}

void MergedCg::setup_impl(const LinearOperator& A) {
  if (A.rows() % 3 != 0) throw InputError("MCG: the size is not divisible by 3 (3x3 blocks)");
  M_.setup(A);
  const Eigen::Index n = A.rows();
  work_.r.resize(n), work_.z.resize(n), work_.p.resize(n), work_.q.resize(n);
}

SolveResult MergedCg::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  const LinearOperator& A = spmv_ ? *spmv_ : system();
  return mcg(A, M_, b, x, with_rhs_floor(params_, b), monitor, &work_);
}

void MergedCg::apply_impl(const Vector& b, Vector& x) const {
  x.setZero();
  require_usable(solve_impl(b, x, nullptr));
}

}  // namespace pmg
