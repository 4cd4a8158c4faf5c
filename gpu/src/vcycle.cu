#include "cuda_check.hpp"
#include "pmg/gpu/solvers.hpp"
#include "pmg/multigrid/smoothers.hpp"

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

// d = c1 d + c2 D⁻¹ r; x += d, one thread per block row.
__global__ void chebyshev_kernel(int block_rows, const double* __restrict__ inv_diag,
                                 const double* __restrict__ r, double* __restrict__ d,
                                 double* __restrict__ x, double c1, double c2) {
  const int I = blockIdx.x * blockDim.x + threadIdx.x;
  if (I < block_rows) detail::chebyshev_block(inv_diag, r, d, x, I, c1, c2);
}

void transfer(const DeviceCsr& T, const DeviceVector& x, DeviceVector& y, bool add) {
  if (T.rows() == 0) return;
  transfer_kernel<<<detail::blocks_for(T.rows()), kThreads>>>(T.view(), x.data(), y.data(), add);
  PMG_LAUNCHED("transfer_kernel");
}

}  // namespace

struct VCycle::Level {
  const Bcsr* A = nullptr;
  BinBcsr host;  ///< the sliced layout, refilled by update()
  std::unique_ptr<DeviceBinBcsr> device;
  DeviceArray<double> inv_diag;
  std::vector<mg::ChebyshevStep> steps;  ///< the CPU smoother's polynomial for this level's λmax
  std::unique_ptr<DeviceCsr> P, R;  ///< from the level below to this one, and back
  mutable DeviceVector b, x, r, d;  ///< b, x: this level's equation when it is not the finest
};

VCycle::VCycle(std::vector<const Bcsr*> matrices, std::vector<const mg::BlockTransfer*> transfers,
               const mg::ChebyshevParams& chebyshev)
    : matrices_(std::move(matrices)), transfers_(std::move(transfers)), chebyshev_(chebyshev) {
  if (matrices_.empty()) throw InputError("gpu::VCycle: no levels");
  if (chebyshev_.kind != mg::ChebyshevKind::first)
    throw InputError("gpu::VCycle: the device smoother is Chebyshev of the first kind only");
  if (transfers_.size() + 1 != matrices_.size())
    throw InputError("gpu::VCycle: need one transfer between each pair of levels");
  for (std::size_t l = 0; l < matrices_.size(); ++l) {
    const Bcsr* A = matrices_[l];
    if (!A || A->rows() != A->cols()) throw InputError("gpu::VCycle: level matrices must be square");
    if (l > 0 && (transfers_[l - 1]->fine_size() != A->rows() ||
                  transfers_[l - 1]->coarse_size() != matrices_[l - 1]->rows()))
      throw InputError("gpu::VCycle: transfer " + std::to_string(l - 1) + " does not match levels " +
                       std::to_string(l - 1) + " and " + std::to_string(l));
  }
  coarse_ = std::make_unique<CholmodSolver>();
  coarse_->setup(*matrices_[0]);
  levels_.resize(matrices_.size());
  for (std::size_t l = 1; l < matrices_.size(); ++l) {
    auto L = std::make_unique<Level>();
    L->A = matrices_[l];
    L->host = BinBcsr(*L->A);
    L->device = std::make_unique<DeviceBinBcsr>(L->host);
    L->P = std::make_unique<DeviceCsr>(transfers_[l - 1]->prolongation());
    L->R = std::make_unique<DeviceCsr>(transfers_[l - 1]->restriction());
    const std::size_t n = static_cast<std::size_t>(L->A->rows());
    L->b.resize(n);
    L->x.resize(n);
    L->r.resize(n);
    L->d.resize(n);
    set_up_smoother(*L);
    levels_[l] = std::move(L);
  }
  // Level 0's right-hand side and solution also live on the device (restricted into, prolongated
  // from); they are the "b, x" of a level without a matrix on the device.
  auto L0 = std::make_unique<Level>();
  L0->b.resize(static_cast<std::size_t>(matrices_[0]->rows()));
  L0->x.resize(static_cast<std::size_t>(matrices_[0]->rows()));
  levels_[0] = std::move(L0);
}

VCycle::~VCycle() = default;

// D⁻¹ (checked SPD) and λmax from the CPU smoother, so both cycles apply the same polynomial.
void VCycle::set_up_smoother(Level& L) const {
  const mg::Chebyshev cheb(*L.A, chebyshev_);
  L.steps = cheb.steps();
  L.inv_diag.upload(cheb.inverse_diagonal());
}

void VCycle::update() {
  for (std::size_t l = 1; l < levels_.size(); ++l) {
    Level& L = *levels_[l];
    L.host.update_values(*L.A);
    L.device->update_values(L.host);
    set_up_smoother(L);
  }
  coarse_->update();
}

index_t VCycle::rows() const { return matrices_.back()->rows(); }

const DeviceBinBcsr& VCycle::finest() const {
  if (levels_.size() < 2) throw InputError("gpu::VCycle: a single level has no device matrix");
  return *levels_.back()->device;
}

// Chebyshev of the first kind on D⁻¹A over [f λmax, λmax]: the steps of mg::chebyshev_steps, as
// mg::Chebyshev::smooth takes them (the residual b - A x before each step).
void VCycle::smooth(const Level& L, const DeviceVector& b, DeviceVector& x) const {
  const int nb = L.A->block_rows();
  const unsigned grid = detail::blocks_for(nb);
  for (const mg::ChebyshevStep& s : L.steps) {
    L.device->residual(b, x, L.r);
    chebyshev_kernel<<<grid, kThreads>>>(nb, L.inv_diag.data(), L.r.data(), L.d.data(), x.data(), s.c1, s.c2);
  }
  PMG_LAUNCHED("chebyshev_kernel");
}

void VCycle::cycle(int l, const DeviceVector& b, DeviceVector& x) const {
  if (l == 0) {
    b.download(coarse_b_);
    coarse_->apply(coarse_b_, coarse_x_);
    x.upload(coarse_x_);
    return;
  }
  const Level& L = *levels_[l];
  Level& C = *levels_[l - 1];
  smooth(L, b, x);
  L.device->residual(b, x, L.r);
  transfer(*L.R, L.r, C.b, false);
  C.x.set_zero();
  cycle(l - 1, C.b, C.x);
  transfer(*L.P, C.x, x, true);
  smooth(L, b, x);
}

void VCycle::cycle(const DeviceVector& b, DeviceVector& x) const {
  const std::size_t n = static_cast<std::size_t>(rows());
  if (b.size() != n || x.size() != n) throw InputError("gpu::VCycle::cycle: vectors do not match the finest level");
  cycle(num_levels() - 1, b, x);
}

void VCycle::apply(const DeviceVector& r, DeviceVector& z) const {
  z.resize(r.size());
  z.set_zero();
  cycle(r, z);
}

}  // namespace pmg::gpu
