#include "pmg/multigrid/cycle.hpp"

#include "pmg/sparse/convergence.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <chrono>
#include <limits>

namespace pmg::mg {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
}  // namespace

CholmodCoarseSolver::CholmodCoarseSolver(const Bcsr& A) : A_(A) {
  chol_.analyze(A.to_csr());
  update();
}

void CholmodCoarseSolver::update() { chol_.factorize(A_.to_csr()); }

MultigridCycle::MultigridCycle(std::vector<const Bcsr*> matrices,
                               std::vector<const BlockTransfer*> transfers,
                               std::vector<std::unique_ptr<Smoother>> smoothers,
                               std::unique_ptr<CoarseSolver> coarse, const CycleParams& params)
    : matrices_(std::move(matrices)),
      transfers_(std::move(transfers)),
      smoothers_(std::move(smoothers)),
      coarse_(std::move(coarse)),
      params_(params) {
  const size_t L = matrices_.size();
  if (L == 0) throw InputError("multigrid: no levels");
  if (transfers_.size() != L - 1 || smoothers_.size() != L - 1)
    throw InputError("multigrid: " + std::to_string(L) + " levels need " + std::to_string(L - 1) +
                     " transfers and smoothers");
  if (!coarse_ || coarse_->rows() != matrices_[0]->rows())
    throw InputError("multigrid: the lowest-level solver does not match level 0");
  for (size_t l = 1; l < L; ++l)
    if (transfers_[l - 1]->fine_size() != matrices_[l]->rows() ||
        transfers_[l - 1]->coarse_size() != matrices_[l - 1]->rows())
      throw InputError("multigrid: transfer " + std::to_string(l - 1) + " does not map level " +
                       std::to_string(l - 1) + " to level " + std::to_string(l));
  if (params_.gamma < 1 || params_.gamma > 2) throw InputError("multigrid: gamma must be 1 or 2");
  reset_timings();
}

bool MultigridCycle::is_symmetric() const {
  for (const auto* t : transfers_)
    if (!t->restriction_is_transpose()) return false;
  return coarse_->is_linear();
}

void MultigridCycle::update() {
  for (auto& s : smoothers_) s->update();
  coarse_->update();
}

void MultigridCycle::reset_timings() const {
  timings_ = CycleTimings{};
  timings_.smoothing.assign(matrices_.size(), 0.0);
}

void MultigridCycle::apply_impl(const Vector& r, Vector& z) const {
  z.setZero();
  cycle(num_levels() - 1, r, z);
}

void MultigridCycle::cycle(int l, const Vector& b, Vector& x) const {
  if (l == 0) {
    const auto t0 = Clock::now();
    coarse_->apply(b, x);
    timings_.coarse += since(t0);
    return;
  }
  if (l == num_levels() - 1) ++timings_.cycles;
  auto t0 = Clock::now();
  smoothers_[l - 1]->pre_smooth(b, x);
  timings_.smoothing[l] += since(t0);
  t0 = Clock::now();
  Vector r, rc, xc;
  matrices_[l]->residual(b, x, r);
  timings_.residual += since(t0);
  t0 = Clock::now();
  transfers_[l - 1]->restrict_to_coarse(r, rc);
  timings_.transfer += since(t0);
  xc = Vector::Zero(rc.size());
  for (int g = 0; g < (l > 1 ? params_.gamma : 1); ++g) cycle(l - 1, rc, xc);
  t0 = Clock::now();
  transfers_[l - 1]->prolongate_add(xc, x);
  timings_.transfer += since(t0);
  t0 = Clock::now();
  smoothers_[l - 1]->post_smooth(b, x);
  timings_.smoothing[l] += since(t0);
}

SolveResult multigrid_solve(const LinearOperator& A, const MultigridCycle& C, const Vector& b,
                            Vector& x, const KrylovParams& params, SolveMonitor* monitor) {
  if (A.rows() != C.rows() || b.size() != A.rows())
    throw InputError("multigrid solve: sizes of operator, cycle and right-hand side differ");
  if (x.size() != b.size()) x = Vector::Zero(b.size());
  if (!ops::all_finite(b) || !ops::all_finite(x))
    throw InputError("multigrid solve: right-hand side or initial guess has NaN/Inf");
  detail::ConvergenceTracker track("PMG", params, monitor);
  Vector r;
  A.residual(b, x, r);
  if (!track.start(ops::norm2(r))) return track.finish(ops::norm2(r));
  for (int it = 1; !track.done(); ++it) {
    C.cycle(b, x);  // the cycle works on the full equation with x as initial guess
    A.residual(b, x, r);
    const double norm = ops::norm2(r);
    // The residual here is the true one: a converged iteration is confirmed at once.
    if (track.after_iteration(it, norm) && track.accept_true_residual(norm)) break;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  return track.finish(ops::norm2(r));
}

SolveResult mgpcg(const LinearOperator& A, const MultigridCycle& C, const Vector& b, Vector& x,
                  const KrylovParams& params, SolveMonitor* monitor, int cycles_per_apply) {
  if (!C.is_symmetric())
    throw InputError("MGPCG needs a symmetric cycle (restriction = prolongation transposed, a linear "
                     "lowest-level solver)");
  if (cycles_per_apply < 1) throw InputError("MGPCG: cycles_per_apply must be >= 1");
  // z = M r with M = cycles_per_apply cycles from z = 0 (symmetric: forward pre-, backward
  // post-smoothing, R = Pᵀ).
  class Repeated final : public LinearOperator {
   public:
    Repeated(const MultigridCycle& c, int k) : c_(c), k_(k) {}
    index_t rows() const override { return c_.rows(); }
    index_t cols() const override { return c_.cols(); }

   private:
    void apply_impl(const Vector& r, Vector& z) const override {
      z.setZero();
      for (int i = 0; i < k_; ++i) c_.cycle(r, z);
    }
    const MultigridCycle& c_;
    int k_;
  } M(C, cycles_per_apply);
  return pcg(A, &M, b, x, params, monitor);
}

}  // namespace pmg::mg
