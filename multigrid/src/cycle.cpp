#include "pmg/multigrid/cycle.hpp"

#include <algorithm>

#include "pmg/sparse/convergence.hpp"
#include "pmg/sparse/vector_ops.hpp"
#include "pmg/sparse/timer.hpp"

#include <chrono>
#include <functional>
#include <limits>

namespace pmg::mg {

namespace {
}  // namespace

MultigridCycle::MultigridCycle(const LevelProvider& levels, const MultigridParams& params,
                               const SmootherFactory& smoothers, std::unique_ptr<Solver> lowest_level)
    : levels_(levels), params_(params), lowest_(std::move(lowest_level)) {
  const int L = levels_.num_levels();
  if (L < 1) throw InputError("multigrid: no levels");
  if (params_.gamma < 1 || params_.gamma > 2) throw InputError("multigrid: gamma must be 1 (V) or 2 (W)");
  if (params_.cycles < 1) throw InputError("multigrid: cycles per application must be >= 1");
  if (!lowest_) throw InputError("multigrid: no lowest-level solver");
  for (int l = 1; l < L; ++l) {
    smoothers_.push_back(smoothers(l));
    if (!smoothers_.back()) throw InputError("multigrid: no smoother for " + levels_.level_name(l));
  }
}

std::string MultigridCycle::name() const {
  return params_.gamma == 1 ? "multigrid (V-cycle)" : "multigrid (W-cycle)";
}

std::string MultigridCycle::describe() const {
  const int L = num_levels();
  auto unknowns = [&](int l) -> index_t {  // known once set up
    if (transfers_.empty()) return 0;
    return l >= 1 ? transfers_[l - 1].fine_size() : transfers_[0].coarse_size();
  };
  std::string s = std::to_string(L) + " levels (";
  for (int l = L - 1; l >= 0; --l) {
    s += levels_.level_name(l);
    if (const index_t n = unknowns(l); n > 0) s += " " + std::to_string(n);
    if (l > 0) s += ", ";
  }
  s += unknowns(L - 1) > 0 ? " unknowns); " : "); ";
  s += params_.coarse_operator == CoarseOperator::galerkin ? "Galerkin coarse operators" : "geometric coarse operators";
  if (params_.matrix_free) s += ", matrix-free above the lowest level";
  if (params_.interpolating_restriction) s += ", interpolating restriction";
  s += "; smoothing";
  for (int l = L - 1; l >= 1; --l) s += (l == L - 1 ? " " : ", ") + smoothers_[l - 1]->name();
  const std::string lowest = lowest_->describe();
  s += "; lowest level " + lowest_->name() + (lowest.empty() ? "" : " (" + lowest + ")");
  s += "; " + std::to_string(params_.cycles) + (params_.cycles == 1 ? " cycle" : " cycles") + " per application";
  long constrained = 0;
  if (!transfers_.empty())
    for (char c : transfers_.back().fine_constraints()) constrained += c;
  if (constrained > 0) s += "; " + std::to_string(constrained) + " components constrained on their own (finest level)";
  return s;
}

bool MultigridCycle::is_linear() const {
  for (const auto& s : smoothers_)
    if (!s->is_linear()) return false;
  return lowest_->is_linear();
}

bool MultigridCycle::is_symmetric() const {
  if (params_.interpolating_restriction) return false;
  // Pre- and post-smoothing are adjoint for every Smoother whose own apply (pre then post) is
  // symmetric: Gauss–Seidel's forward/backward pair, or Richardson with a symmetric M.
  for (const auto& s : smoothers_)
    if (!s->is_linear() || !s->is_symmetric()) return false;
  return lowest_->is_linear() && lowest_->is_symmetric();
}

const Bcsr& MultigridCycle::level_matrix(int l) const {
  const int L = num_levels();
  if (params_.coarse_operator == CoarseOperator::galerkin && l < L - 1) return galerkin_.at(l).matrix();
  return levels_.matrix(l);
}

const LinearOperator& MultigridCycle::level_operator(int l) const {
  if (params_.matrix_free && l > 0) return *levels_.matrix_free_operator(l);
  return level_matrix(l);
}

void MultigridCycle::timed_stage(const std::string& name, const std::function<void()>& stage) {
  const auto t0 = Clock::now();
  stage();
  setup_timings_.parts.emplace_back(name, seconds_since(t0));
}

void MultigridCycle::setup_impl(const LinearOperator& A) {
  const int L = num_levels();
  setup_timings_ = TimingBreakdown{{}, 1, "set-up"};
  if (params_.matrix_free) {
    if (params_.coarse_operator == CoarseOperator::galerkin)
      throw InputError("multigrid: matrix-free levels need geometric coarse operators, not Galerkin products");
    for (int l = 1; l < L; ++l)
      if (!levels_.matrix_free_operator(l))
        throw InputError("multigrid: " + levels_.level_name(l) + " has no matrix-free operator (an FEM "
                         "degree hierarchy has them for degree >= 2)");
  }
  if (A.rows() != level_operator(L - 1).rows())
    throw InputError("multigrid: the operator has " + std::to_string(A.rows()) + " rows, the finest " +
                     "level (" + levels_.level_name(L - 1) + ") " +
                     std::to_string(level_operator(L - 1).rows()) +
                     ": set the solver up on the finest level's own matrix (levels.matrix(num_levels() - 1)); "
                     "user levels remove the rows of clamped nodes, so the matrix as given is larger");
  if (params_.coarse_operator == CoarseOperator::geometric)
    for (int l = 0; l < L - 1; ++l)
      if (!levels_.has_matrix(l))
        throw InputError("multigrid: " + levels_.level_name(l) + " has no matrix of its own (only the "
                         "finest was given): use coarse_operator=galerkin");
  const bool galerkin = params_.coarse_operator == CoarseOperator::galerkin;
  timed_stage(galerkin ? "transfers and Galerkin products" : "transfers", [&] {
    transfers_.clear();
    for (int l = 1; l < L; ++l) {
      if (params_.interpolating_restriction)
        transfers_.emplace_back(levels_.prolongation(l), levels_.interpolating_restriction(l));
      else
        transfers_.emplace_back(levels_.prolongation(l));
      const BlockTransfer& T = transfers_.back();
      // The provider's sizes (Galerkin products are formed below, from these transfers).
      auto rows = [&](int k) {
        return params_.matrix_free && k > 0 ? levels_.matrix_free_operator(k)->rows() : levels_.matrix(k).rows();
      };
      if (T.fine_size() != rows(l) ||
          (params_.coarse_operator == CoarseOperator::geometric && T.coarse_size() != rows(l - 1)))
        throw InputError("multigrid: the prolongation of " + levels_.level_name(l) + " does not map " +
                         levels_.level_name(l - 1) + " to it");
    }
    // Components constrained on their own, finest first: a Galerkin level's are the coarse
    // components no free fine component takes anything from.
    auto rows_of = [&](int l) -> index_t {
      if (l >= 1) return transfers_[l - 1].fine_size();
      return transfers_.empty() ? levels_.matrix(0).rows() : transfers_[0].coarse_size();
    };
    auto provided = [&](int l) {
      const std::vector<char>* m = levels_.constrained_dofs(l);
      if (m && static_cast<index_t>(m->size()) != rows_of(l))
        throw InputError("multigrid: " + levels_.level_name(l) + " lists " + std::to_string(m->size()) +
                         " constrained-component flags for " + std::to_string(rows_of(l)) + " unknowns");
      return m ? *m : std::vector<char>{};
    };
    std::vector<char> fine_mask = provided(L - 1);
    for (int l = L - 1; l >= 1; --l) {
      BlockTransfer& T = transfers_[l - 1];
      std::vector<char> coarse_mask = galerkin ? T.unreachable_coarse(fine_mask) : provided(l - 1);
      if (std::find(coarse_mask.begin(), coarse_mask.end(), 1) == coarse_mask.end()) coarse_mask.clear();
      if (!fine_mask.empty() || !coarse_mask.empty()) T.constrain(fine_mask, coarse_mask);
      fine_mask = std::move(coarse_mask);
    }
    galerkin_.clear();
    if (galerkin) {
      galerkin_.resize(L > 0 ? L - 1 : 0);
      for (int l = L - 2; l >= 0; --l) galerkin_[l] = GalerkinProduct(transfers_[l], level_matrix(l + 1));
    }
  });
  // A set-up that fails on a level says which, and for a Galerkin product where to look.
  auto on_level = [&](int l, const std::function<void()>& set_up) {
    try {
      set_up();
    } catch (const InputError&) {
      throw;
    } catch (const Error& e) {
      const bool product = params_.coarse_operator == CoarseOperator::galerkin && l < L - 1;
      throw Error("multigrid: the set-up of " + levels_.level_name(l) + " failed: " + e.what() +
                  (product ? " (this level's matrix is the Galerkin product P^T A P: a prolongation "
                             "without full column rank makes it singular; check the prolongations)"
                           : ""));
    }
  };
  for (int l = L - 1; l >= 1; --l)
    timed_stage("smoother " + levels_.level_name(l),
                [&] { on_level(l, [&] { smoothers_[l - 1]->setup(level_operator(l)); }); });
  timed_stage("lowest level (" + lowest_->name() + ")", [&] { on_level(0, [&] { lowest_->setup(level_matrix(0)); }); });
  work_.assign(L, Work{});
  for (int l = 1; l < L; ++l) {
    work_[l].r.resize(level_operator(l).rows());
    work_[l].rc.resize(level_operator(l - 1).rows());
    work_[l].xc.resize(level_operator(l - 1).rows());
  }
  solve_r_.resize(A.rows());
  reset_timings();
}

void MultigridCycle::refresh_galerkin() {
  // Pattern and plan kept from setup(): values only, finest first (level l reads level l + 1).
  for (int l = num_levels() - 2; l >= 0; --l) galerkin_[l].update(level_matrix(l + 1));
}

void MultigridCycle::update_impl() {
  setup_timings_ = TimingBreakdown{{}, 1, "update"};
  if (params_.coarse_operator == CoarseOperator::galerkin) timed_stage("Galerkin products", [&] { refresh_galerkin(); });
  for (int l = num_levels() - 1; l >= 1; --l)
    timed_stage("smoother " + levels_.level_name(l), [&] { smoothers_[l - 1]->update(); });
  timed_stage("lowest level (" + lowest_->name() + ")", [&] { lowest_->update(); });
}

TimingBreakdown MultigridCycle::timings() const {
  TimingBreakdown b;
  b.unit = "cycle";
  b.count = timings_.cycles;
  for (int l = num_levels() - 1; l >= 1; --l)
    b.parts.emplace_back("smoothing " + levels_.level_name(l), timings_.smoothing[l]);
  b.parts.emplace_back("residuals", timings_.residual);
  b.parts.emplace_back("transfers", timings_.transfer);
  b.parts.emplace_back("lowest-level solve", timings_.lowest_level);
  return b;
}

void MultigridCycle::reset_timings() const {
  timings_ = CycleTimings{};
  timings_.smoothing.assign(num_levels(), 0.0);
}

void MultigridCycle::apply_impl(const Vector& r, Vector& z) const {
  z.setZero(r.size());
  for (int k = 0; k < params_.cycles; ++k) cycle(num_levels() - 1, r, z, k == 0);
}

void MultigridCycle::cycle(int l, const Vector& b, Vector& x, bool x_is_zero) const {
  if (l == 0) {
    const auto t0 = Clock::now();
    lowest_->apply(b, x);
    timings_.lowest_level += seconds_since(t0);
    return;
  }
  if (l == num_levels() - 1) ++timings_.cycles;
  Work& w = work_[l];
  auto t0 = Clock::now();
  if (x_is_zero) smoothers_[l - 1]->pre_smooth_from_zero(b, x);
  else smoothers_[l - 1]->pre_smooth(b, x);
  timings_.smoothing[l] += seconds_since(t0);
  t0 = Clock::now();
  level_operator(l).residual(b, x, w.r);
  timings_.residual += seconds_since(t0);
  t0 = Clock::now();
  transfers_[l - 1].restrict_to_coarse(w.r, w.rc);
  timings_.transfer += seconds_since(t0);
  w.xc.setZero();
  for (int g = 0; g < (l > 1 ? params_.gamma : 1); ++g) cycle(l - 1, w.rc, w.xc, g == 0);
  t0 = Clock::now();
  transfers_[l - 1].prolongate_add(w.xc, x);
  timings_.transfer += seconds_since(t0);
  t0 = Clock::now();
  smoothers_[l - 1]->post_smooth(b, x);
  timings_.smoothing[l] += seconds_since(t0);
}

SolveResult MultigridCycle::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  const LinearOperator& A = system();
  detail::ConvergenceTracker track("PMG", with_rhs_floor(params_.iteration, b), monitor);
  Vector& r = solve_r_;
  A.residual(b, x, r);
  if (!track.start(ops::norm2(r))) return track.finish(ops::norm2(r));
  for (int it = 1; !track.done(); ++it) {
    cycle(b, x);  // the cycle works on the full equation with x as initial guess
    A.residual(b, x, r);
    const double norm = ops::norm2(r);
    // The residual here is the true one: a converged iteration is confirmed at once.
    if (track.after_iteration(it, norm) && track.accept_true_residual(norm)) break;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  return track.finish(ops::norm2(r));
}

}  // namespace pmg::mg
