// pmg/gpu/solvers.hpp — solvers on the GPU: the merged CG (MCG), the library PCG it is measured
// against, and a p-multigrid V-cycle with a Chebyshev smoother.
//
// Every solver stops by the rules of pmg/sparse/krylov.hpp (relative residual, true-residual
// confirmation, divergence, NaN/Inf, stagnation, iteration limit) through the same tracker as the
// CPU solvers, and agrees with its CPU counterpart to round-off:
//   gpu::Mcg        ≡ pmg::mcg          (BIN-BCSR, block Jacobi)
//   gpu::LibraryPcg ≡ pmg::pcg + BlockJacobiPreconditioner
//   gpu::VCycle     ≡ mg::MultigridCycle with mg::Chebyshev smoothers and CHOLMOD below
//   gpu::mgpcg_solve ≡ pmg::mgpcg: PCG preconditioned by one gpu::VCycle
#pragma once

#include "pmg/gpu/matrices.hpp"
#include "pmg/multigrid/chebyshev.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/sparse/solver.hpp"
#include "pmg/sparse/krylov.hpp"

#include <memory>
#include <vector>

namespace pmg::gpu {

/// Inverted 3x3 diagonal blocks on the device (z = D⁻¹ r).
class DeviceBlockJacobi {
 public:
  /// Uploads M's inverted blocks (M must be set up). Throws CudaError on failure.
  explicit DeviceBlockJacobi(const BlockJacobiPreconditioner& M) { update(M); }
  /// Re-uploads M's inverted blocks (after M.update()).
  void update(const BlockJacobiPreconditioner& M) { inv_.upload(M.inverse_blocks()); }
  /// Number of scalar rows (3 per block).
  index_t rows() const { return static_cast<index_t>(inv_.size() / 3); }
  /// Device pointer to the inverted blocks, 9 doubles per block row, row-major.
  const double* inverse_blocks() const { return inv_.data(); }
  /// z = D⁻¹ r (z resized); r must have rows() entries (InputError otherwise).
  void apply(const DeviceVector& r, DeviceVector& z) const;

 private:
  DeviceArray<double> inv_;
};

/// Merged CG in three kernels per iteration, scalars kept on the device (no host round trip):
///   (1) q = A s, σ = sᵀq           last block reduces σ, sets α = ρ/σ       reads A, s; writes q
///   (2) x += α s, r -= α q, z = D⁻¹r, ρ' = rᵀz, rr = rᵀr; last block sets β = ρ'/ρ, ρ = ρ'
///                                                          reads x, s, r, q, D⁻¹; writes x, r, z
///   (3) s = z + β s                                         reads z, s; writes s
/// Vector traffic 16n doubles per iteration besides the matrix (as the CPU mcg). The host reads
/// the per-iteration scalars (σ, ρ', rr) every params.check_every iterations (1 reads after
/// every iteration; 10 is the GPU's natural choice), so the history still has every iteration;
/// up to check_every - 1 iterations run past the one that met the tolerance. A σ or ρ' that is
/// not positive (or NaN) stops the queued iterations on the device, so after a breakdown x is the
/// CPU mcg's iterate. Block reductions are in a fixed order: results are bitwise repeatable.
class Mcg {
 public:
  /// Keeps references to A and M; workspace is allocated here, once.
  Mcg(const DeviceBinBcsr& A, const DeviceBlockJacobi& M);
  ~Mcg();
  /// x: initial guess in, solution out (resized to zero if empty).
  SolveResult solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& params = {},
                    SolveMonitor* monitor = nullptr) const;

 private:
  struct Workspace;
  const DeviceBinBcsr& A_;
  const DeviceBlockJacobi& M_;
  std::unique_ptr<Workspace> w_;
};

/// Block-Jacobi PCG assembled from library calls, the baseline MCG is measured against:
/// cusparseDbsrmv for A and for D⁻¹ (a block-diagonal BSR matrix), cublasDdot, cublasDaxpy and
/// cublasDgeam with the scalars on the host (three dot products per iteration, each a round trip).
class LibraryPcg {
 public:
  /// Uploads copies of A and of M's inverted blocks (M set up on A) and creates the cuBLAS handle.
  /// Throws InputError when the sizes differ, CudaError when a CUDA library call fails.
  LibraryPcg(const Bcsr& A, const BlockJacobiPreconditioner& M);
  ~LibraryPcg();
  LibraryPcg(const LibraryPcg&) = delete;
  LibraryPcg& operator=(const LibraryPcg&) = delete;
  /// Block-Jacobi PCG for A x = b with the stopping rules of `params`; x: initial guess in,
  /// solution out (zero when its size does not match b). Throws SolveError on failure unless
  /// params.throw_on_failure is false.
  SolveResult solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& params = {},
                    SolveMonitor* monitor = nullptr) const;

 private:
  CusparseBsr A_, Dinv_;
  void* cublas_ = nullptr;  ///< cublasHandle_t
  mutable DeviceVector r_, z_, p_, q_;
};

/// p-multigrid V-cycle on the GPU: every level above the lowest runs there (BIN-BCSR or, on
/// matrix-free levels, DeviceElasticityOperator residuals; Chebyshev smoothing on D⁻¹A of the
/// first, fourth or optimised fourth kind; transfers P ⊗ I₃ and R ⊗ I₃ as scalar CSR kernels); the
/// lowest level is solved on the host by the factory's direct method (CHOLMOD; one download and
/// one upload per cycle, of the lowest level's size). Built from the same inputs as mg::MultigridCycle (coarsest first); keeps
/// references to the matrices, operators and transfers. λmax and D⁻¹ of each level come from
/// mg::Chebyshev on the host operator, so the GPU and CPU cycles apply the same polynomial.
class VCycle {
 public:
  /// Level matrices coarsest first (square), and one transfer per pair of adjacent levels
  /// (transfers[l-1] maps level l-1 to level l). Factorises the lowest level with the factory's
  /// direct method (pmg/sparse/defaults.hpp; the multigrid methods are registered here) and
  /// uploads the others. Throws InputError when sizes do not match, CudaError on a device failure.
  VCycle(std::vector<const Bcsr*> matrices, std::vector<const mg::BlockTransfer*> transfers,
         const mg::ChebyshevParams& chebyshev = {});
  /// The same with matrix-free levels: operators[l] (a fem::ElasticityOperator, or nullptr for
  /// the assembled matrices[l], which may then be nullptr itself) for every level; the lowest
  /// must be assembled. InputError for another operator type or held components.
  VCycle(std::vector<const Bcsr*> matrices, std::vector<const mg::BlockTransfer*> transfers,
         const mg::ChebyshevParams& chebyshev, std::vector<const LinearOperator*> operators);
  ~VCycle();
  /// The matrices' values (or the matrix-free operators' rotations and weights) changed:
  /// re-upload, new D⁻¹ and λmax, refactorise.
  void update();
  /// Number of scalar rows of the finest level.
  index_t rows() const;
  /// Number of levels, the lowest included.
  int num_levels() const { return static_cast<int>(matrices_.size()); }
  /// One cycle improving x for A x = b (finest level) in place.
  void cycle(const DeviceVector& b, DeviceVector& x) const;
  /// z = C r (one cycle from z = 0): the cycle as a preconditioner.
  void apply(const DeviceVector& r, DeviceVector& z) const;
  /// The finest level's matrix on the device (InputError where that level is matrix-free).
  const DeviceBinBcsr& finest() const;
  /// Whether the finest level is matrix-free.
  bool matrix_free() const;
  /// y = A x on the finest level.
  void multiply(const DeviceVector& x, DeviceVector& y) const;
  /// r = b - A x on the finest level.
  void residual(const DeviceVector& b, const DeviceVector& x, DeviceVector& r) const;

 private:
  struct Level;
  void set_up_smoother(Level& L) const;
  void cycle(int level, const DeviceVector& b, DeviceVector& x, bool x_is_zero) const;
  void smooth(const Level& L, const DeviceVector& b, DeviceVector& x, bool x_is_zero) const;

  std::vector<const Bcsr*> matrices_;
  std::vector<const mg::BlockTransfer*> transfers_;
  mg::ChebyshevParams chebyshev_;
  /// levels_[0] holds only the lowest level's b and x on the device (its matrix is the host's)
  std::vector<std::unique_ptr<Level>> levels_;
  std::unique_ptr<Solver> coarse_;  ///< the lowest level's solver, from the factory (kDefaultDirectMethod)
  mutable Vector coarse_b_, coarse_x_;
};

/// PMG on the GPU: x <- x + C (b - A x) with the stopping rules of mg::MultigridCycle::solve (the
/// CPU's stationary multigrid; the true residual's norm is read back once per cycle).
SolveResult multigrid_solve(const VCycle& C, const DeviceVector& b, DeviceVector& x,
                            const KrylovParams& params = {}, SolveMonitor* monitor = nullptr);

/// MGPCG on the GPU: PCG on the cycle's finest operator, preconditioned by one cycle from zero
/// (VCycle::apply), with the loop and stopping rules of pmg::pcg (params.flexible: the flexible
/// β = -zᵀq / σ). Dot products are read back to the host, three per iteration.
SolveResult mgpcg_solve(const VCycle& C, const DeviceVector& b, DeviceVector& x,
                        const KrylovParams& params = {}, SolveMonitor* monitor = nullptr);

/// Device vector primitives (default stream). dot() allocates its reduction scratch per call;
/// the solvers above keep theirs.
double dot(const DeviceVector& a, const DeviceVector& b);
/// y += alpha x
void axpy(double alpha, const DeviceVector& x, DeviceVector& y);

}  // namespace pmg::gpu
