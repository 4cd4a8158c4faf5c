// Block-Jacobi PCG from cuSPARSE and cuBLAS calls: the library baseline of the merged CG.
#include "cuda_check.hpp"
#include "pmg/gpu/solvers.hpp"
#include "pmg/sparse/convergence.hpp"

#include <cmath>
#include <limits>

namespace pmg::gpu {

namespace {

/// The inverted diagonal blocks as a block-diagonal BCSR matrix.
Bcsr block_diagonal(const std::vector<double>& blocks) {
  const index_t nb = static_cast<index_t>(blocks.size() / Bcsr::kBlockSize);
  auto p = std::make_shared<BlockPattern>();
  p->rows = p->cols = nb;
  p->row_ptr.resize(static_cast<std::size_t>(nb) + 1);
  p->col_idx.resize(static_cast<std::size_t>(nb));
  for (index_t I = 0; I <= nb; ++I) p->row_ptr[I] = I;
  for (index_t I = 0; I < nb; ++I) p->col_idx[I] = I;
  return Bcsr(p, blocks);
}

cublasHandle_t handle_of(void* h) { return static_cast<cublasHandle_t>(h); }

}  // namespace

LibraryPcg::LibraryPcg(const Bcsr& A, const BlockJacobiPreconditioner& M)
    : A_(A), Dinv_(block_diagonal(M.inverse_blocks())) {
  if (M.rows() != A.rows()) throw InputError("gpu::LibraryPcg: matrix and preconditioner differ in size");
  cublasHandle_t h = nullptr;
  PMG_CUBLAS(PMG_VENDOR(cublas, cublasCreate)(&h));
  cublas_ = h;
}

LibraryPcg::~LibraryPcg() {
  try {  // a destroy function the opened library lacks leaves the handle: a destructor never throws
    if (cublas_) PMG_VENDOR(cublas, cublasDestroy)(handle_of(cublas_));
  } catch (...) {
  }
}

SolveResult LibraryPcg::solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& params,
                              SolveMonitor* monitor) const {
  const int n = A_.rows();
  if (b.size() != static_cast<std::size_t>(n))
    throw InputError("gpu::LibraryPcg: right-hand side does not match the matrix");
  if (x.size() != b.size()) {
    x.resize(b.size());
    x.set_zero();
  }
  cublasHandle_t h = handle_of(cublas_);
  auto dot = [&](const DeviceVector& u, const DeviceVector& v) {
    double d = 0.0;
    PMG_CUBLAS(PMG_VENDOR(cublas, cublasDdot)(h, n, u.data(), 1, v.data(), 1, &d));  // host pointer mode: waits
    return d;
  };
  auto axpy = [&](double a, const DeviceVector& u, DeviceVector& v) {
    PMG_CUBLAS(PMG_VENDOR(cublas, cublasDaxpy)(h, n, &a, u.data(), 1, v.data(), 1));
  };
  // r = b - A x
  auto residual = [&]() {
    A_.multiply(x, q_);
    r_.assign(b);
    axpy(-1.0, q_, r_);
  };
  pmg::detail::ConvergenceTracker track("GPU library PCG", params, monitor);
  residual();
  double rr = dot(r_, r_);
  if (!track.start(std::sqrt(rr), std::sqrt(dot(b, b)))) return track.finish(std::sqrt(rr));
  double rho = 0.0;
  auto restart = [&](int it) {
    Dinv_.multiply(r_, z_);
    p_.assign(z_);
    rho = dot(r_, z_);
    return track.check_positive(rho, "r^T M^{-1} r", it);
  };
  if (!restart(0)) return track.finish(std::sqrt(rr));
  for (int it = 1; !track.done(); ++it) {
    A_.multiply(p_, q_);
    const double sigma = dot(p_, q_);
    if (!track.check_positive(sigma, "p^T A p", it)) break;
    const double alpha = rho / sigma;
    axpy(alpha, p_, x);
    axpy(-alpha, q_, r_);
    track.add_energy_decrease(alpha * rho);
    rr = dot(r_, r_);
    if (track.after_iteration(it, std::sqrt(rr))) {
      residual();
      if (track.accept_true_residual(std::sqrt(dot(r_, r_)))) break;
      if (!restart(it)) break;
      continue;
    }
    if (track.done()) break;
    Dinv_.multiply(r_, z_);
    const double rho_new = dot(r_, z_);
    if (!track.check_positive(rho_new, "r^T M^{-1} r", it)) break;
    // p = z + β p in one call (geam on an n x 1 matrix, in place in p)
    const double one = 1.0, beta = rho_new / rho;
    PMG_CUBLAS(PMG_VENDOR(cublas, cublasDgeam)(h, CUBLAS_OP_N, CUBLAS_OP_N, n, 1, &one, z_.data(), n, &beta, p_.data(), n,
                           p_.data(), n));
    rho = rho_new;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  residual();
  return track.finish(std::sqrt(dot(r_, r_)));
}

}  // namespace pmg::gpu
