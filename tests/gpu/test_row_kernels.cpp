// The per-thread bodies of the CUDA kernels (pmg/gpu/detail/row_kernels.hpp), run on the host one
// "thread" after another and compared with the host formats. Runs everywhere, GPU or not: the
// indexing of every kernel is checked even where the kernels themselves cannot run.
#include "../sparse/fixture.hpp"
#include "hierarchy.hpp"
#include "pmg/gpu/detail/row_kernels.hpp"
#include "pmg/multigrid/chebyshev.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace pmg;
using gpu::detail::BinBcsrView;
using KernelView = gpu::detail::CsrView;

namespace {

KernelView kernel_view(const Bcsr& A) {
  return {A.block_rows(), A.pattern().row_ptr.data(), A.pattern().col_idx.data(), A.values().data()};
}

KernelView kernel_view(const Csr& A) {
  return {A.rows(), A.pattern().row_ptr.data(), A.pattern().col_idx.data(), A.values().data()};
}

// Every matrix a kernel must handle: the irregular fixture (bins straddling block rows, a row with
// no diagonal block, an empty row) and the cubic elasticity matrix.
std::vector<Bcsr> matrices() {
  std::vector<Bcsr> m;
  m.push_back(Bcsr::from_block_triplets(23, 23, test::irregular_blocks()));
  test::GpuCantilever c(3, 1);
  m.push_back(c.A());
  return m;
}

}  // namespace

// One warp as the device runs it: 32 lanes, then v += shfl_xor(v, off) in every lane at once for
// off = L/2 … 1 (a butterfly, not bin_bcsr_fold's halving loop), then the group's first lane writes.
static void emulate_warp(const BinBcsrView& A, const double* x, double* y, int bin) {
  double v[32][3];
  int row[32];
  for (int lane = 0; lane < 32; ++lane) row[lane] = bin_bcsr_lane(A, x, bin, lane, v[lane]);
  for (int off = A.lanes / 2; off > 0; off /= 2) {
    double w[32][3];
    for (int lane = 0; lane < 32; ++lane)
      for (int c = 0; c < 3; ++c) w[lane][c] = v[lane][c] + v[lane ^ off][c];
    std::copy(&w[0][0], &w[0][0] + 96, &v[0][0]);
  }
  for (int lane = 0; lane < 32; lane += A.lanes)
    if (row[lane] >= 0)
      for (int c = 0; c < 3; ++c) y[3 * row[lane] + c] = v[lane][c];
}

TEST_CASE("BIN-BCSR warp kernel, lane by lane, matches BCSR and the host BIN-BCSR bit for bit",
          "[gpu-host]") {
  for (const Bcsr& A : matrices())
    for (int lanes : {0, 1, 2, 4, 8, 16, 32})
      for (index_t window : {0, 1, 3}) {
        const BinBcsr B(A, {lanes, window});
        INFO("rows " << A.rows() << ", lanes " << B.lanes() << ", window " << B.sort_window());
        const Vector x = test::random_vector(A.cols(), 3);
        Vector y_ref, y_host(A.rows()), y = Vector::Constant(A.rows(), std::nan(""));
        A.apply(x, y_ref);
        B.multiply(x.data(), y_host.data());
        const BinBcsrView v = B.view();
        for (int bin = 0; bin < v.num_bins; ++bin) emulate_warp(v, x.data(), y.data(), bin);
        CHECK(test::rel_diff(y, y_ref) < 1e-14);  // also: no row left unwritten (NaN)
        CHECK(y == y_host);
      }
}

TEST_CASE("BCSR row kernel, thread by thread, matches the host BCSR SpMV", "[gpu-host]") {
  for (const Bcsr& A : matrices()) {
    const Vector x = test::random_vector(A.cols(), 4);
    Vector y_ref, y(A.rows());
    A.apply(x, y_ref);
    for (int row = 0; row < A.rows(); ++row) y[row] = gpu::detail::bcsr_row(kernel_view(A), x.data(), row);
    CHECK(test::rel_diff(y, y_ref) < 1e-14);
  }
}

TEST_CASE("transfer row kernel applies P ⊗ I₃ and R ⊗ I₃ like BlockTransfer", "[gpu-host]") {
  test::GpuCantilever c(3, 1);
  for (const mg::BlockTransfer* T : c.transfers()) {
    const Vector xc = test::random_vector(T->coarse_size(), 5), rf = test::random_vector(T->fine_size(), 6);
    Vector xf_ref, rc_ref;
    T->prolongate(xc, xf_ref);
    T->restrict_to_coarse(rf, rc_ref);
    Vector xf(T->fine_size()), rc(T->coarse_size());
    const KernelView P = kernel_view(T->prolongation()), R = kernel_view(T->restriction());
    for (int i = 0; i < P.rows; ++i) gpu::detail::transfer_row(P, xc.data(), xf.data(), i, false);
    for (int i = 0; i < R.rows; ++i) gpu::detail::transfer_row(R, rf.data(), rc.data(), i, false);
    CHECK(test::rel_diff(xf, xf_ref) < 1e-14);
    CHECK(test::rel_diff(rc, rc_ref) < 1e-14);
    // add = true accumulates
    Vector acc = xf_ref;
    for (int i = 0; i < P.rows; ++i) gpu::detail::transfer_row(P, xc.data(), acc.data(), i, true);
    CHECK(test::rel_diff(acc, Vector(2.0 * xf_ref)) < 1e-14);
  }
}

TEST_CASE("the GPU Chebyshev step sequence reproduces mg::Chebyshev smoothing", "[gpu-host]") {
  test::GpuCantilever c(2, 1);
  const Bcsr& A = c.A();
  mg::ChebyshevParams p;
  const mg::Chebyshev cheb(A, p);
  const Vector b = test::random_vector(A.rows(), 7);
  Vector x_ref = test::random_vector(A.rows(), 8);
  Vector x = x_ref;
  cheb.pre_smooth(b, x_ref);
  // The recurrence of gpu::VCycle::smooth, with the kernel bodies run on the host.
  const std::vector<double>& inv = cheb.inverse_diagonal();
  const double lmax = cheb.lambda_max(), lmin = p.lower_fraction * lmax;
  const double theta = 0.5 * (lmax + lmin), delta = 0.5 * (lmax - lmin), sigma = theta / delta;
  double rho = 1.0 / sigma;
  Vector r, d = Vector::Constant(A.rows(), std::nan(""));  // step 0 must not read d
  auto step = [&](double c1, double c2) {
    A.residual(b, x, r);
    for (int I = 0; I < A.block_rows(); ++I)
      gpu::detail::chebyshev_block(inv.data(), r.data(), d.data(), x.data(), I, c1, c2);
  };
  step(0.0, 1.0 / theta);
  for (int k = 1; k < p.degree; ++k) {
    const double rho_new = 1.0 / (2.0 * sigma - rho);
    step(rho_new * rho, 2.0 * rho_new / delta);
    rho = rho_new;
  }
  CHECK(test::rel_diff(x, x_ref) < 1e-12);
}

TEST_CASE("the GPU fourth-kind step sequence reproduces mg::Chebyshev smoothing", "[gpu-host]") {
  test::GpuCantilever c(2, 1);
  const Bcsr& A = c.A();
  for (mg::ChebyshevKind kind : {mg::ChebyshevKind::fourth, mg::ChebyshevKind::optimal_fourth}) {
    mg::ChebyshevParams p;
    p.kind = kind;
    p.degree = 4;
    const mg::Chebyshev cheb(A, p);
    const Vector b = test::random_vector(A.rows(), 7);
    Vector x_ref = test::random_vector(A.rows(), 8);
    Vector x = x_ref;
    cheb.pre_smooth(b, x_ref);
    // The recurrence of gpu::VCycle::smooth for the fourth kinds, kernel bodies run on the host:
    // one residual, then per step d = c1 d + c2 D⁻¹ r, x += w d, r -= A d.
    const std::vector<double>& inv = cheb.inverse_diagonal();
    const std::vector<mg::ChebyshevStep>& steps = cheb.steps();
    REQUIRE(steps.size() == 4);
    // From x, and from x = 0 with r = b (VCycle's zero start, the CPU's pre_smooth_from_zero).
    auto smooth = [&](Vector& v, bool from_zero) {
      Vector r, q, d = Vector::Constant(A.rows(), std::nan(""));  // step 0 must not read d
      if (from_zero) r = b;
      else A.residual(b, v, r);
      for (std::size_t k = 0; k < steps.size(); ++k) {
        for (int I = 0; I < A.block_rows(); ++I)
          gpu::detail::chebyshev_block(inv.data(), r.data(), d.data(), v.data(), I, steps[k].c1, steps[k].c2,
                                       steps[k].weight);
        if (k + 1 < steps.size()) {
          A.apply(d, q);
          r -= q;
        }
      }
    };
    smooth(x, false);
    CHECK(test::rel_diff(x, x_ref) < 1e-12);
    Vector z_ref = Vector::Zero(A.rows()), z = Vector::Zero(A.rows());
    cheb.pre_smooth_from_zero(b, z_ref);
    smooth(z, true);
    CHECK(test::rel_diff(z, z_ref) < 1e-12);
  }
}
