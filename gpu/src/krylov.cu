#include "bin_bcsr.cuh"
#include "cuda_check.hpp"
#include "pmg/gpu/solvers.hpp"
#include "pmg/sparse/convergence.hpp"
#include "reduce.cuh"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pmg::gpu {

namespace {

using detail::BinBcsrView;
using detail::kThreads;

/// Scalars that live on the device between the kernels of an iteration.
struct Scalars {
  double rho = 0.0;    ///< rᵀz of the current iteration
  double alpha = 0.0;  ///< set by step 1
  double beta = 0.0;   ///< set by step 2
  double dot = 0.0;    ///< result of dot_kernel
  double init_rz = 0.0, init_rr = 0.0;
  unsigned int counter = 0;  ///< grid_sum ticket (each kernel leaves it at 0)
  /// Set when σ or ρ' is not positive (breakdown, NaN): the step kernels still queued in the chunk
  /// then return at once, so x stays the iterate the host reports, as in the CPU MCG. Only a
  /// kernel's last block writes it, after every block of that kernel has read it, so all blocks
  /// of a later kernel see the same value. The restart kernel clears it.
  unsigned int halt = 0;
};

/// What the host reads back per iteration.
struct Record {
  double sigma;   ///< sᵀAs
  double rz;      ///< rᵀz after the update
  double rr;      ///< rᵀr after the update
  double energy;  ///< α ρ: the decrease of the energy functional
};

// (1) q = A s and σ = sᵀq, one warp per bin (detail::bin_bcsr_warp); the last block sets α = ρ/σ.
__global__ void step1_kernel(BinBcsrView A, const double* __restrict__ s, double* __restrict__ q,
                             double* partials, Scalars* sc, Record* rec) {
  if (sc->halt) return;
  double qi[3];
  const int I = detail::bin_bcsr_warp(A, s, qi);
  double v[1] = {0.0};
  if (I >= 0)
    for (int c = 0; c < 3; ++c) {
      q[3LL * I + c] = qi[c];
      v[0] += qi[c] * s[3LL * I + c];
    }
  double total[1];
  if (detail::grid_sum(v, partials, &sc->counter, total) && threadIdx.x == 0) {
    rec->sigma = total[0];
    sc->alpha = sc->rho / total[0];
    if (!(total[0] > 0.0)) sc->halt = 1;  // also NaN
  }
}

// (2) x += α s, r -= α q, z = D⁻¹ r, sums rᵀz and rᵀr, one thread per block row; the last block
// sets β = ρ'/ρ and ρ = ρ'.
__global__ void step2_kernel(int block_rows, const double* __restrict__ inv_diag,
                             const double* __restrict__ s, const double* __restrict__ q,
                             double* __restrict__ x, double* __restrict__ r, double* __restrict__ z,
                             double* partials, Scalars* sc, Record* rec) {
  if (sc->halt) return;
  const int I = blockIdx.x * blockDim.x + threadIdx.x;
  const double alpha = sc->alpha;
  double v[2] = {0.0, 0.0};
  if (I < block_rows) {
    const long long o = 3LL * I;
    double ri[3], zi[3];
    for (int c = 0; c < 3; ++c) {
      x[o + c] += alpha * s[o + c];
      ri[c] = r[o + c] - alpha * q[o + c];
      r[o + c] = ri[c];
    }
    block3_apply(inv_diag + 9LL * I, ri, zi);
    for (int c = 0; c < 3; ++c) {
      z[o + c] = zi[c];
      v[0] += ri[c] * zi[c];
      v[1] += ri[c] * ri[c];
    }
  }
  double total[2];
  if (detail::grid_sum(v, partials, &sc->counter, total) && threadIdx.x == 0) {
    rec->rz = total[0];
    rec->rr = total[1];
    rec->energy = alpha * sc->rho;
    sc->beta = total[0] / sc->rho;
    sc->rho = total[0];
    if (!(total[0] > 0.0)) sc->halt = 1;
  }
}

// (3) s = z + β s
__global__ void step3_kernel(int n, const double* __restrict__ z, double* __restrict__ s,
                             const Scalars* sc) {
  if (sc->halt) return;
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) s[i] = z[i] + sc->beta * s[i];
}

// Restart: z = D⁻¹ r, s = z, ρ = rᵀz (also rᵀr).
__global__ void restart_kernel(int block_rows, const double* __restrict__ inv_diag,
                               const double* __restrict__ r, double* __restrict__ z,
                               double* __restrict__ s, double* partials, Scalars* sc) {
  const int I = blockIdx.x * blockDim.x + threadIdx.x;
  double v[2] = {0.0, 0.0};
  if (I < block_rows) {
    const long long o = 3LL * I;
    double zi[3];
    block3_apply(inv_diag + 9LL * I, r + o, zi);
    for (int c = 0; c < 3; ++c) {
      z[o + c] = s[o + c] = zi[c];
      v[0] += r[o + c] * zi[c];
      v[1] += r[o + c] * r[o + c];
    }
  }
  double total[2];
  if (detail::grid_sum(v, partials, &sc->counter, total) && threadIdx.x == 0) {
    sc->rho = sc->init_rz = total[0];
    sc->init_rr = total[1];
    sc->halt = 0;
  }
}

__global__ void dot_kernel(int n, const double* __restrict__ a, const double* __restrict__ b,
                           double* partials, Scalars* sc) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  double v[1] = {i < n ? a[i] * b[i] : 0.0};
  double total[1];
  if (detail::grid_sum(v, partials, &sc->counter, total) && threadIdx.x == 0) sc->dot = total[0];
}

__global__ void block_jacobi_kernel(int block_rows, const double* __restrict__ inv_diag,
                                    const double* __restrict__ r, double* __restrict__ z) {
  const int I = blockIdx.x * blockDim.x + threadIdx.x;
  if (I < block_rows) block3_apply(inv_diag + 9LL * I, r + 3LL * I, z + 3LL * I);
}

__global__ void axpy_kernel(int n, double alpha, const double* __restrict__ x, double* __restrict__ y) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) y[i] += alpha * x[i];
}

// p = z + β p.
__global__ void xpby_kernel(int n, const double* __restrict__ z, double beta, double* __restrict__ p) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) p[i] = z[i] + beta * p[i];
}

/// Device scalars and scratch for the reductions of one solver or of dot().
struct Reducer {
  explicit Reducer(std::size_t n) : partials(2 * std::max<std::size_t>(detail::blocks_for(n), 1)) {
    scalars.set_zero();
  }
  DeviceArray<Scalars> scalars{1};
  DeviceArray<double> partials;
  Scalars read() const {
    Scalars s;
    scalars.download(&s);
    return s;
  }
};

std::size_t size_of(index_t n) { return static_cast<std::size_t>(n); }

}  // namespace

// ---- primitives ----------------------------------------------------------------------------------

namespace {
double dot_with(Reducer& red, const DeviceVector& a, const DeviceVector& b) {
  if (a.size() != b.size()) throw InputError("gpu::dot: vectors differ in size");
  if (a.empty()) return 0.0;
  const int n = static_cast<int>(a.size());
  dot_kernel<<<detail::blocks_for(n), kThreads>>>(n, a.data(), b.data(), red.partials.data(),
                                                  red.scalars.data());
  PMG_LAUNCHED("dot_kernel");
  return red.read().dot;
}
}  // namespace

double dot(const DeviceVector& a, const DeviceVector& b) {
  Reducer red(a.size());
  return dot_with(red, a, b);
}

void axpy(double alpha, const DeviceVector& x, DeviceVector& y) {
  if (x.size() != y.size()) throw InputError("gpu::axpy: vectors differ in size");
  if (x.empty()) return;
  const int n = static_cast<int>(x.size());
  axpy_kernel<<<detail::blocks_for(n), kThreads>>>(n, alpha, x.data(), y.data());
  PMG_LAUNCHED("axpy_kernel");
}

void DeviceBlockJacobi::apply(const DeviceVector& r, DeviceVector& z) const {
  if (r.size() != size_of(rows())) throw InputError("DeviceBlockJacobi::apply: r does not match");
  z.resize(r.size());
  const int nb = rows() / 3;
  if (nb == 0) return;
  block_jacobi_kernel<<<detail::blocks_for(nb), kThreads>>>(nb, inv_.data(), r.data(), z.data());
  PMG_LAUNCHED("block_jacobi_kernel");
}

// ---- MCG -----------------------------------------------------------------------------------------

struct Mcg::Workspace {
  /// n: unknowns; threads: the most threads any kernel with a grid sum runs (step 1 runs one warp
  /// per bin, more threads than unknowns when bins have unused lanes).
  Workspace(index_t n, long long threads)
      : red(std::max<std::size_t>(size_of(n), static_cast<std::size_t>(threads))), r(size_of(n)),
        z(size_of(n)), s(size_of(n)), q(size_of(n)) {}
  Reducer red;
  DeviceVector r, z, s, q;
  DeviceArray<Record> records;
};

Mcg::Mcg(const DeviceBinBcsr& A, const DeviceBlockJacobi& M) : A_(A), M_(M) {
  if (M.rows() != A.rows()) throw InputError("gpu::Mcg: matrix and preconditioner differ in size");
  w_ = std::make_unique<Workspace>(A.rows(), A.threads());
}

Mcg::~Mcg() = default;

SolveResult Mcg::solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& params,
                       SolveMonitor* monitor) const {
  const index_t n = A_.rows();
  if (b.size() != size_of(n)) throw InputError("gpu::Mcg: right-hand side does not match the matrix");
  if (x.size() != b.size()) {
    x.resize(b.size());
    x.set_zero();
  }
  Workspace& w = *w_;
  pmg::detail::ConvergenceTracker track("GPU MCG", params, monitor);
  const int nb = n / 3;
  const unsigned g_rows = detail::blocks_for(n), g_blocks = detail::blocks_for(nb),
                 g_bins = detail::blocks_for(A_.threads());
  double* partials = w.red.partials.data();
  Scalars* sc = w.red.scalars.data();

  // r = b - A x; z = D⁻¹ r; s = z; ρ = rᵀz. Returns ||r||.
  auto restart = [&]() {
    A_.residual(b, x, w.r);
    if (nb > 0) {
      restart_kernel<<<g_blocks, kThreads>>>(nb, M_.inverse_blocks(), w.r.data(), w.z.data(),
                                            w.s.data(), partials, sc);
      PMG_LAUNCHED("restart_kernel");
    }
    return w.red.read();
  };
  Scalars s0 = restart();
  if (!track.start(std::sqrt(s0.init_rr), std::sqrt(dot_with(w.red, b, b)))) return track.finish(std::sqrt(s0.init_rr));
  if (!track.check_positive(s0.init_rz, "r^T M^{-1} r", 0)) return track.finish(std::sqrt(s0.init_rr));

  const int k = params.check_every;
  w.records.resize(static_cast<std::size_t>(k));
  std::vector<Record> host(static_cast<std::size_t>(k));
  int it = 0;
  while (!track.done()) {
    const int chunk = std::max(1, std::min(k, params.max_iterations - it));
    for (int j = 0; j < chunk; ++j) {
      Record* rec = w.records.data() + j;
      step1_kernel<<<g_bins, kThreads>>>(A_.view(), w.s.data(), w.q.data(), partials, sc, rec);
      step2_kernel<<<g_blocks, kThreads>>>(nb, M_.inverse_blocks(), w.s.data(), w.q.data(), x.data(),
                                           w.r.data(), w.z.data(), partials, sc, rec);
      step3_kernel<<<g_rows, kThreads>>>(n, w.z.data(), w.s.data(), sc);
    }
    PMG_LAUNCHED("MCG steps");
    detail::copy_to_host(host.data(), w.records.data(), sizeof(Record) * chunk);  // synchronises
    for (int j = 0; j < chunk && !track.done(); ++j) {
      ++it;
      const Record& r = host[static_cast<std::size_t>(j)];
      if (!track.check_positive(r.sigma, "s^T A s", it)) break;
      track.add_energy_decrease(r.energy);
      // As the CPU mcg with check_every = k: only the last iteration of a chunk may stop.
      const bool converged = track.after_iteration(it, std::sqrt(r.rr)) && j == chunk - 1;
      if (converged) {
        const Scalars t = restart();
        if (track.accept_true_residual(std::sqrt(t.init_rr))) break;
        if (!track.check_positive(t.init_rz, "r^T M^{-1} r", it)) break;
        break;  // go on from the true residual: the restart kernel reset z, s and ρ
      }
      if (!track.done() && !track.check_positive(r.rz, "r^T M^{-1} r", it)) break;
    }
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  A_.residual(b, x, w.q);
  return track.finish(std::sqrt(dot_with(w.red, w.q, w.q)));
}

// ---- PMG -----------------------------------------------------------------------------------------

SolveResult multigrid_solve(const VCycle& C, const DeviceVector& b, DeviceVector& x,
                            const KrylovParams& params, SolveMonitor* monitor) {
  if (b.size() != size_of(C.rows()))
    throw InputError("gpu::multigrid_solve: right-hand side does not match the cycle");
  if (x.size() != b.size()) {
    x.resize(b.size());
    x.set_zero();
  }
  pmg::detail::ConvergenceTracker track("GPU PMG", params, monitor);
  Reducer red(b.size());
  DeviceVector r(b.size());
  C.residual(b, x, r);
  double norm = std::sqrt(dot_with(red, r, r));
  if (!track.start(norm, std::sqrt(dot_with(red, b, b)))) return track.finish(norm);
  for (int it = 1; !track.done(); ++it) {
    C.cycle(b, x);
    C.residual(b, x, r);
    norm = std::sqrt(dot_with(red, r, r));
    if (track.after_iteration(it, norm) && track.accept_true_residual(norm)) break;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  return track.finish(norm);
}

// The loop of pmg::pcg (sparse/src/krylov.cpp), line for line, on device vectors.
SolveResult mgpcg_solve(const VCycle& C, const DeviceVector& b, DeviceVector& x, const KrylovParams& params,
                        SolveMonitor* monitor) {
  if (b.size() != size_of(C.rows())) throw InputError("gpu::mgpcg_solve: right-hand side does not match the cycle");
  if (x.size() != b.size()) {
    x.resize(b.size());
    x.set_zero();
  }
  pmg::detail::ConvergenceTracker track("GPU MGPCG", params, monitor);
  const std::size_t n = b.size();
  const int ni = static_cast<int>(n);
  Reducer red(n);
  DeviceVector r(n), z(n), p(n), q(n);
  auto norm2 = [&](const DeviceVector& v) { return std::sqrt(dot_with(red, v, v)); };
  C.residual(b, x, r);
  if (!track.start(norm2(r), norm2(b))) return track.finish(norm2(r));
  double rho = 0.0;
  auto restart = [&](int it) {
    C.apply(r, z);
    p.assign(z);
    rho = dot_with(red, r, z);
    return track.check_positive(rho, "r^T M^{-1} r", it);
  };
  if (!restart(0)) return track.finish(norm2(r));
  for (int it = 1; !track.done(); ++it) {
    C.multiply(p, q);
    const double sigma = dot_with(red, p, q);
    if (!track.check_positive(sigma, "p^T A p", it)) break;
    const double alpha = rho / sigma;
    axpy(alpha, p, x);
    axpy(-alpha, q, r);
    track.add_energy_decrease(alpha * rho);
    if (track.after_iteration(it, norm2(r))) {
      C.residual(b, x, r);  // recursive residual converged: confirm with the true one
      if (track.accept_true_residual(norm2(r))) break;
      if (!restart(it)) break;
      continue;
    }
    if (track.done()) break;
    C.apply(r, z);
    const double rho_new = dot_with(red, r, z);
    if (!track.check_positive(rho_new, "r^T M^{-1} r", it)) break;
    const double beta = params.flexible ? -dot_with(red, z, q) / sigma : rho_new / rho;
    xpby_kernel<<<detail::blocks_for(ni), kThreads>>>(ni, z.data(), beta, p.data());  // p = z + β p
    PMG_LAUNCHED("xpby_kernel");
    rho = rho_new;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  C.residual(b, x, q);
  return track.finish(norm2(q));
}

}  // namespace pmg::gpu
