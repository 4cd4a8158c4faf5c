#include "cuda_check.hpp"
#include "pmg/gpu/matrix_free.hpp"
#include "pmg/gpu/solvers.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/smoothers.hpp"
#include "pmg/sparse/defaults.hpp"

namespace pmg::gpu {

namespace {

using detail::CsrView;
using detail::kThreads;

// y = (T ⊗ I₃) x (add: y +=), one thread per row of the scalar transfer T.
__global__ void transfer_kernel(CsrView T, const double* __restrict__ x, double* __restrict__ y,
                                bool add) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < T.rows) detail::transfer_row(T, x, y, i, add);
}

// d = c1 d + c2 D⁻¹ r; x += w d, one thread per block row.
__global__ void chebyshev_kernel(int block_rows, const double* __restrict__ inv_diag,
                                 const double* __restrict__ r, double* __restrict__ d,
                                 double* __restrict__ x, double c1, double c2, double w) {
  const int I = blockIdx.x * blockDim.x + threadIdx.x;
  if (I < block_rows) detail::chebyshev_block(inv_diag, r, d, x, I, c1, c2, w);
}

// r = b - y (r may be y).
__global__ void subtract_kernel(int n, const double* __restrict__ b, const double* y, double* r) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) r[i] = b[i] - y[i];
}

// r -= q.
__global__ void decrement_kernel(int n, const double* __restrict__ q, double* __restrict__ r) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) r[i] -= q[i];
}

void transfer(const DeviceCsr& T, const DeviceVector& x, DeviceVector& y, bool add) {
  if (T.rows() == 0) return;
  transfer_kernel<<<detail::blocks_for(T.rows()), kThreads>>>(T.view(), x.data(), y.data(), add);
  PMG_LAUNCHED("transfer_kernel");
}

}  // namespace

struct VCycle::Level {
  const Bcsr* A = nullptr;                      ///< assembled level (BIN-BCSR on the device), or
  const fem::ElasticityOperator* op = nullptr;  ///< a matrix-free one
  index_t n = 0;
  BinBcsr host;  ///< the sliced layout, refilled by update()
  std::unique_ptr<DeviceBinBcsr> device;
  std::unique_ptr<DeviceElasticityOperator> mf;
  DeviceArray<double> inv_diag;
  std::unique_ptr<mg::Chebyshev> cheb;   ///< the CPU smoother on the host operator: D⁻¹ and λmax
  std::vector<mg::ChebyshevStep> steps;  ///< the CPU smoother's polynomial for this level's λmax
  std::unique_ptr<DeviceCsr> P, R;  ///< from the level below to this one, and back
  mutable DeviceVector b, x, r, d, q;  ///< b, x: this level's equation when it is not the finest

  /// The host operator the CPU smoother would run on.
  const LinearOperator& host_operator() const {
    return op ? static_cast<const LinearOperator&>(*op) : static_cast<const LinearOperator&>(*A);
  }
  void multiply(const DeviceVector& v, DeviceVector& y) const {
    if (mf) mf->multiply(v, y);
    else device->multiply(v, y);
  }
  void residual(const DeviceVector& rhs, const DeviceVector& v, DeviceVector& res) const {
    if (n == 0) return;
    if (!mf) return device->residual(rhs, v, res);
    mf->multiply(v, res);
    subtract_kernel<<<detail::blocks_for(n), kThreads>>>(static_cast<int>(n), rhs.data(), res.data(), res.data());
    PMG_LAUNCHED("subtract_kernel");
  }
};

VCycle::VCycle(std::vector<const Bcsr*> matrices, std::vector<const mg::BlockTransfer*> transfers,
               const mg::ChebyshevParams& chebyshev)
    : VCycle(std::move(matrices), std::move(transfers), chebyshev, {}) {}

VCycle::VCycle(std::vector<const Bcsr*> matrices, std::vector<const mg::BlockTransfer*> transfers,
               const mg::ChebyshevParams& chebyshev, std::vector<const LinearOperator*> operators)
    : matrices_(std::move(matrices)), transfers_(std::move(transfers)), chebyshev_(chebyshev) {
  if (matrices_.empty()) throw InputError("gpu::VCycle: no levels");
  if (transfers_.size() + 1 != matrices_.size())
    throw InputError("gpu::VCycle: need one transfer between each pair of levels");
  if (!operators.empty() && operators.size() != matrices_.size())
    throw InputError("gpu::VCycle: give one operator per level (nullptr: the assembled matrix) or none");
  operators.resize(matrices_.size(), nullptr);
  if (operators[0]) throw InputError("gpu::VCycle: the lowest level must be assembled (CHOLMOD factorises it)");
  std::vector<index_t> rows(matrices_.size());
  for (std::size_t l = 0; l < matrices_.size(); ++l) {
    const Bcsr* A = matrices_[l];
    if (operators[l]) {
      if (!operators[l]->elasticity_operator())
        throw InputError("gpu::VCycle: level " + std::to_string(l) +
                         "'s operator is not a matrix-free elasticity operator (fem::ElasticityOperator)");
      rows[l] = operators[l]->rows();
    } else {
      if (!A || A->rows() != A->cols()) throw InputError("gpu::VCycle: level matrices must be square");
      rows[l] = A->rows();
    }
    if (l > 0 && (transfers_[l - 1]->fine_size() != rows[l] || transfers_[l - 1]->coarse_size() != rows[l - 1]))
      throw InputError("gpu::VCycle: transfer " + std::to_string(l - 1) + " does not match levels " +
                       std::to_string(l - 1) + " and " + std::to_string(l));
  }
  mg::register_solvers();  // the direct method of the lowest level (idempotent)
  coarse_ = make_solver(Config::from_pairs({std::string("method=") + kDefaultDirectMethod}, "gpu::VCycle lowest level"));
  coarse_->setup(*matrices_[0]);
  levels_.resize(matrices_.size());
  for (std::size_t l = 1; l < matrices_.size(); ++l) {
    auto L = std::make_unique<Level>();
    L->n = rows[l];
    if (operators[l]) {
      L->op = operators[l]->elasticity_operator();
      L->mf = std::make_unique<DeviceElasticityOperator>(*L->op);
    } else {
      L->A = matrices_[l];
      L->host = BinBcsr(*L->A);
      L->device = std::make_unique<DeviceBinBcsr>(L->host);
    }
    L->P = std::make_unique<DeviceCsr>(transfers_[l - 1]->prolongation());
    L->R = std::make_unique<DeviceCsr>(transfers_[l - 1]->restriction());
    const std::size_t n = static_cast<std::size_t>(L->n);
    L->b.resize(n);
    L->x.resize(n);
    L->r.resize(n);
    L->d.resize(n);
    L->q.resize(n);
    set_up_smoother(*L);
    levels_[l] = std::move(L);
  }
  // Level 0's right-hand side and solution also live on the device (restricted into, prolongated
  // from); they are the "b, x" of a level without a matrix on the device.
  auto L0 = std::make_unique<Level>();
  L0->n = rows[0];
  L0->b.resize(static_cast<std::size_t>(rows[0]));
  L0->x.resize(static_cast<std::size_t>(rows[0]));
  levels_[0] = std::move(L0);
}

VCycle::~VCycle() = default;

// D⁻¹ (checked SPD) and λmax from the CPU smoother, so both cycles apply the same polynomial. The
// smoother is kept: update() refreshes it as the CPU cycle does (chebyshev_.update_iterations
// warm-started power steps, or a new estimate).
void VCycle::set_up_smoother(Level& L) const {
  if (L.cheb) L.cheb->update();
  else L.cheb = std::make_unique<mg::Chebyshev>(L.host_operator(), chebyshev_);
  L.steps = L.cheb->steps();
  L.inv_diag.upload(L.cheb->inverse_diagonal());
}

void VCycle::update() {
  for (std::size_t l = 1; l < levels_.size(); ++l) {
    Level& L = *levels_[l];
    if (L.mf) {
      L.mf->refresh(*L.op);
    } else {
      L.host.update_values(*L.A);
      L.device->update_values(L.host);
    }
    set_up_smoother(L);
  }
  coarse_->update();
}

index_t VCycle::rows() const { return levels_.back()->n; }

const DeviceBinBcsr& VCycle::finest() const {
  if (levels_.size() < 2) throw InputError("gpu::VCycle: a single level has no device matrix");
  if (!levels_.back()->device) throw InputError("gpu::VCycle: the finest level is matrix-free");
  return *levels_.back()->device;
}

bool VCycle::matrix_free() const { return levels_.size() > 1 && levels_.back()->mf != nullptr; }

void VCycle::multiply(const DeviceVector& x, DeviceVector& y) const {
  if (levels_.size() < 2) throw InputError("gpu::VCycle: a single level has no device operator");
  if (x.size() != static_cast<std::size_t>(rows())) throw InputError("gpu::VCycle::multiply: x does not match the finest level");
  y.resize(x.size());
  levels_.back()->multiply(x, y);
}

void VCycle::residual(const DeviceVector& b, const DeviceVector& x, DeviceVector& r) const {
  if (levels_.size() < 2) throw InputError("gpu::VCycle: a single level has no device operator");
  if (x.size() != static_cast<std::size_t>(rows()) || b.size() != x.size())
    throw InputError("gpu::VCycle::residual: vectors do not match the finest level");
  r.resize(x.size());
  levels_.back()->residual(b, x, r);
}

// Chebyshev on D⁻¹A: the steps of mg::chebyshev_steps, as mg::Chebyshev::smooth takes them. First
// kind: the residual b - A x before each step; fourth kinds: one residual, then r -= A d after each
// step with the unweighted d, and x += w d (Lottes' weights for the optimised kind).
// From x = 0 (x_is_zero) the first residual is b itself: one product fewer, as the CPU smoother's
// pre_smooth_from_zero.
void VCycle::smooth(const Level& L, const DeviceVector& b, DeviceVector& x, bool x_is_zero) const {
  if (L.n == 0) return;
  const int nb = static_cast<int>(L.n / 3);
  const unsigned grid = detail::blocks_for(nb);
  const bool first_kind = chebyshev_.kind == mg::ChebyshevKind::first;
  const int m = static_cast<int>(L.steps.size());
  for (int k = 0; k < m; ++k) {
    const mg::ChebyshevStep& s = L.steps[static_cast<std::size_t>(k)];
    if (k == 0 && x_is_zero) L.r.assign(b);
    else if (k == 0 || first_kind) L.residual(b, x, L.r);
    chebyshev_kernel<<<grid, kThreads>>>(nb, L.inv_diag.data(), L.r.data(), L.d.data(), x.data(), s.c1, s.c2,
                                         s.weight);
    PMG_LAUNCHED("chebyshev_kernel");
    if (!first_kind && k + 1 < m) {
      L.multiply(L.d, L.q);
      decrement_kernel<<<detail::blocks_for(L.n), kThreads>>>(static_cast<int>(L.n), L.q.data(), L.r.data());
      PMG_LAUNCHED("decrement_kernel");
    }
  }
}

void VCycle::cycle(int l, const DeviceVector& b, DeviceVector& x, bool x_is_zero) const {
  if (l == 0) {
    b.download(coarse_b_);
    coarse_->apply(coarse_b_, coarse_x_);
    x.upload(coarse_x_);
    return;
  }
  const Level& L = *levels_[l];
  Level& C = *levels_[l - 1];
  smooth(L, b, x, x_is_zero);
  L.residual(b, x, L.r);
  transfer(*L.R, L.r, C.b, false);
  C.x.set_zero();
  cycle(l - 1, C.b, C.x, true);
  transfer(*L.P, C.x, x, true);
  smooth(L, b, x, false);
}

void VCycle::cycle(const DeviceVector& b, DeviceVector& x) const {
  const std::size_t n = static_cast<std::size_t>(rows());
  if (b.size() != n || x.size() != n) throw InputError("gpu::VCycle::cycle: vectors do not match the finest level");
  cycle(num_levels() - 1, b, x, false);
}

void VCycle::apply(const DeviceVector& r, DeviceVector& z) const {
  z.resize(r.size());
  z.set_zero();
  const std::size_t n = static_cast<std::size_t>(rows());
  if (r.size() != n) throw InputError("gpu::VCycle::apply: vectors do not match the finest level");
  cycle(num_levels() - 1, r, z, true);
}

}  // namespace pmg::gpu
