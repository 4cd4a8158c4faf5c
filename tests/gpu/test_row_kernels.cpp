// The per-thread bodies of the CUDA kernels (pmg/gpu/detail/row_kernels.hpp), run on the host one
// "thread" after another and compared with the host formats. Runs everywhere, GPU or not: the
// indexing of every kernel is checked even where the kernels themselves cannot run.
#include "../sparse/fixture.hpp"
#include "hierarchy.hpp"
#include "pmg/gpu/detail/row_kernels.hpp"
#include "pmg/multigrid/chebyshev.hpp"

#include <catch2/catch.hpp>

using namespace pmg;
using gpu::detail::BinBcsrView;
using gpu::detail::CsrView;

namespace {

BinBcsrView view_of(const BinBcsr& A) {
  BinBcsrView v;
  v.rows = A.rows();
  v.width = A.width().data();
  v.first_block_row = A.first_block_row().data();
  v.bin_block_rows = A.bin_block_rows().data();
  v.col_offset = A.col_offset().data();
  v.val_offset = A.val_offset().data();
  v.columns = A.columns().data();
  v.values = A.values().data();
  v.diag = A.diagonal_blocks().data();
  return v;
}

CsrView view_of(const Bcsr& A) {
  return {A.block_rows(), A.pattern().row_ptr.data(), A.pattern().col_idx.data(), A.values().data()};
}

CsrView view_of(const Csr& A) {
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

TEST_CASE("BIN-BCSR row kernel, thread by thread, matches the host BIN-BCSR SpMV", "[gpu-host]") {
  for (const Bcsr& A : matrices()) {
    const BinBcsr B(A);
    const Vector x = test::random_vector(A.cols(), 3);
    Vector y_ref, y(A.rows());
    A.apply(x, y_ref);
    const BinBcsrView v = view_of(B);
    for (int row = 0; row < v.rows; ++row) y[row] = gpu::detail::bin_bcsr_row(v, x.data(), row);
    CHECK(test::rel_diff(y, y_ref) < 1e-14);
  }
}

TEST_CASE("BCSR row kernel, thread by thread, matches the host BCSR SpMV", "[gpu-host]") {
  for (const Bcsr& A : matrices()) {
    const Vector x = test::random_vector(A.cols(), 4);
    Vector y_ref, y(A.rows());
    A.apply(x, y_ref);
    for (int row = 0; row < A.rows(); ++row) y[row] = gpu::detail::bcsr_row(view_of(A), x.data(), row);
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
    const CsrView P = view_of(T->prolongation()), R = view_of(T->restriction());
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
