#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/levels.hpp"

#include "pmg/multigrid/chebyshev.hpp"

#include <algorithm>

#include "pmg/sparse/convergence.hpp"
#include "pmg/sparse/vector_ops.hpp"
#include "pmg/sparse/timer.hpp"

#include <chrono>
#include <exception>
#include <cmath>
#include <functional>
#include <cstdio>
#include <limits>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pmg::mg {

namespace {
/// Vectors shorter than this are converted on the calling thread (a parallel region costs more).
constexpr std::ptrdiff_t kParallelLength = 16384;
}  // namespace

MultigridCycle::MultigridCycle(std::shared_ptr<const LevelProvider> levels, const MultigridParams& params,
                               const SmootherFactory& smoothers, std::unique_ptr<Solver> lowest_level)
    : MultigridCycle(*levels, params, smoothers, std::move(lowest_level)) {
  owned_levels_ = std::move(levels);
}

MultigridCycle::MultigridCycle(const LevelProvider& levels, const MultigridParams& params,
                               const SmootherFactory& smoothers, std::unique_ptr<Solver> lowest_level)
    : levels_(levels), params_(params), lowest_(std::move(lowest_level)) {
  if (const auto* view = dynamic_cast<const LevelsFrom*>(&levels_)) provider_lowest_ = view->skip();
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
  for (int l = L - 1; l >= 1; --l) {
    s += (l == L - 1 ? " " : ", ") + smoothers_[l - 1]->name();
    if (const std::string d = smoothers_[l - 1]->describe(); !d.empty()) s += " (" + d + ")";
  }
  if (!params_.smoother_choice.empty()) s += " [" + params_.smoother_choice + "]";
  const std::string lowest = lowest_->describe();
  s += "; lowest level " + lowest_->name() + (lowest.empty() ? "" : " (" + lowest + ")");
  if (!single_.empty()) s += "; levels above the lowest in float";
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
  for (int l = L - 1; l >= 1; --l) {
    // A cycle in float has its Chebyshev smoothers keep D⁻¹ in float (and estimate λmax in float).
    if (auto* chebyshev = dynamic_cast<Chebyshev*>(smoothers_[l - 1].get()))
      chebyshev->set_single_precision(params_.single_precision);
    timed_stage("smoother " + levels_.level_name(l),
                [&] { on_level(l, [&] { smoothers_[l - 1]->setup(level_operator(l)); }); });
  }
  timed_stage("lowest level (" + lowest_->name() + ")", [&] { on_level(0, [&] { lowest_->setup(level_matrix(0)); }); });
  itemise_lowest();
  work_.assign(L, Work{});
  for (int l = 1; l < L; ++l) {
    work_[l].r.resize(level_operator(l).rows());
    work_[l].rc.resize(level_operator(l - 1).rows());
    work_[l].xc.resize(level_operator(l - 1).rows());
  }
  solve_r_.resize(A.rows());
  single_.clear();
  if (params_.single_precision) prepare_single(true);
  reset_timings();
}

void MultigridCycle::prepare_single(bool setup) {
  const int L = num_levels();
  if (setup) {
    // Why level l cannot run in float ("" if it can).
    auto obstacle = [&](int l) -> std::string {
      if (!params_.matrix_free) return "it needs the matrix-free levels (operator=matrix-free)";
      const BlockTransfer& T = transfers_[l - 1];
      if (!T.fine_constraints().empty() || !T.coarse_constraints().empty())
        return "it takes no components constrained on their own (symmetry planes)";
      if (!level_operator(l).single_precision_source())
        return "it needs operators that apply in float; " + levels_.level_name(l) + "'s does not";
      const auto* chebyshev = dynamic_cast<const Chebyshev*>(smoothers_[l - 1].get());
      if (!chebyshev || chebyshev->preconditioner())
        return "it smooths with Chebyshev on the diagonal blocks only; " + levels_.level_name(l) + " has " +
               smoothers_[l - 1]->name();
      return "";
    };
    for (int l = 1; l < L; ++l)
      if (const std::string why = obstacle(l); !why.empty()) {
        if (params_.single_where_possible) return;  // precision=auto: these levels stay in double
        throw InputError("multigrid: precision=single: " + why);
      }
    if (const std::string why = float_range_obstacle(); !why.empty()) {
      if (params_.single_where_possible) return;  // precision=auto: double, where float's range is the cause
      throw InputError("multigrid: precision=single: " + why + "; use precision=double (or auto)");
    }
    single_.assign(L, SingleLevel{});
    for (int l = 1; l < L; ++l) {
      SingleLevel& s = single_[l];
      s.op = level_operator(l).single_precision_source();
      s.smoother = dynamic_cast<const Chebyshev*>(smoothers_[l - 1].get());
      const BlockTransfer& T = transfers_[l - 1];
      s.p_values.assign(T.prolongation().values().begin(), T.prolongation().values().end());
      s.r_values.assign(T.restriction().values().begin(), T.restriction().values().end());
      const Eigen::Index n = level_operator(l).rows(), nc = level_operator(l - 1).rows();
      s.r.resize(n), s.d.resize(n), s.rc.resize(nc), s.xc.resize(nc);
    }
    lowest_b_.resize(level_operator(0).rows());
    lowest_x_.resize(level_operator(0).rows());
  }
  for (int l = 1; l < L; ++l) refresh_single(l);
}

std::string MultigridCycle::float_range_obstacle() const {
  // The cycle in float scales each residual to a largest entry of 1 (apply_impl), so what must fit
  // float is the operators' scale, read off their inverse diagonal blocks: entries beyond
  // [1e-30, 1e30] (float's normal range is about [1.2e-38, 3.4e38]) would overflow or flush the
  // products to zero (a Young's modulus of 1e45 Pa, or of 1e-40).
  static_assert(Chebyshev::kSingleLow == 1e-30 && Chebyshev::kSingleHigh == 1e30, "the message below names the range");
  for (int l = 1; l < num_levels(); ++l) {
    const auto* chebyshev = dynamic_cast<const Chebyshev*>(smoothers_[l - 1].get());
    if (!chebyshev) continue;
    // The smoother checked its D⁻¹ in its setup() or update() (a float cycle asked it for float).
    if (const double scale = chebyshev->single_range_violation(); scale != 0.0) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "%s's inverse diagonal blocks reach %.3g, beyond what float holds with margin ([1e-30, 1e30]): "
                    "the operator's scale (its Young's modulus) is outside float's range",
                    levels_.level_name(l).c_str(), scale);
      return text;
    }
  }
  return "";
}

void MultigridCycle::refresh_single(int l) {
  // The smoother's own float D⁻¹: a cycle in float asked its Chebyshev smoothers for one
  // (set_single_precision), and float_range_obstacle() refuses the levels where they keep none.
  SingleLevel& s = single_[l];
  const std::vector<float>& own = s.smoother->inverse_diagonal_single();
  if (own.empty()) throw Error("multigrid: " + levels_.level_name(l) + "'s smoother keeps no float D^-1");
  s.inv = own.data();
}

void MultigridCycle::refresh_galerkin() {
  // Pattern and plan kept from setup(): values only, finest first (level l reads level l + 1).
  for (int l = num_levels() - 2; l >= 0; --l) galerkin_[l].update(level_matrix(l + 1));
}

bool MultigridCycle::overlap_lowest_update() const {
#ifdef _OPENMP
  if (omp_get_max_threads() < 2 || omp_get_active_level() > 0 || !lowest_->update_is_serial()) return false;
  for (int l = 1; l < num_levels(); ++l) {
    const auto* c = dynamic_cast<const Chebyshev*>(smoothers_[l - 1].get());
    const LinearOperator& A = level_operator(l);
    if (!c || c->preconditioner() ||
        !(A.elasticity_operator() || A.bcsr_matrix() || A.bin_bcsr_matrix() || A.csr_matrix()))
      return false;
  }
  return true;
#else
  return false;
#endif
}

void MultigridCycle::update_impl() {
  setup_timings_ = TimingBreakdown{{}, 1, "update"};
  if (params_.coarse_operator == CoarseOperator::galerkin) timed_stage("Galerkin products", [&] { refresh_galerkin(); });
  const int L = num_levels();
  std::vector<double> smoother_seconds(static_cast<size_t>(L), 0.0);
  double lowest_seconds = 0.0;
  auto update_smoothers = [&] {
    for (int l = L - 1; l >= 1; --l) {
      const auto t0 = Clock::now();
      smoothers_[l - 1]->update();
      smoother_seconds[static_cast<size_t>(l)] = seconds_since(t0);
    }
  };
  auto update_lowest = [&] {
    const auto t0 = Clock::now();
    lowest_->update();
    lowest_seconds = seconds_since(t0);
  };
  // The lowest level is refreshed before the float check below, so that an error there leaves the
  // whole cycle consistent.
#ifdef _OPENMP
  if (overlap_lowest_update()) {
    // The lowest level's serial refactorisation on the calling thread (where it ran before),
    // beside the smoothers' updates on the second, whose kernels then run on that thread alone
    // (their parallel regions are nested in this one). The two timings overlap.
    std::exception_ptr failed[2];
#pragma omp parallel num_threads(2)
    {
      const int t = omp_get_thread_num();
      try {
        if (t == 0) update_lowest();
        if (t == 1 || omp_get_num_threads() == 1) update_smoothers();
      } catch (...) {
        failed[t] = std::current_exception();
      }
    }
    if (failed[1]) std::rethrow_exception(failed[1]);
    if (failed[0]) std::rethrow_exception(failed[0]);
  } else
#endif
  {
    update_smoothers();
    update_lowest();
  }
  for (int l = L - 1; l >= 1; --l)
    setup_timings_.parts.emplace_back("smoother " + levels_.level_name(l), smoother_seconds[static_cast<size_t>(l)]);
  setup_timings_.parts.emplace_back("lowest level (" + lowest_->name() + ")", lowest_seconds);
  if (!single_.empty()) {
    if (const std::string why = float_range_obstacle(); !why.empty()) {  // new values beyond float's range
      single_.clear();  // the cycle in double from now on (precision=auto), or after the error below
      if (!params_.single_where_possible)
        throw InputError("multigrid: precision=single: " + why + "; use precision=double (or auto)");
    }
    for (int l = 1; l < static_cast<int>(single_.size()); ++l) refresh_single(l);  // the float D⁻¹ with the smoother's own
  }
  itemise_lowest();
}

void MultigridCycle::itemise_lowest() {
  // A lowest level with stages of its own (a cycle over coarser meshes) lists them in place of its
  // total, each named under "lowest level: ".
  const TimingBreakdown inner = lowest_->setup_timings();
  if (inner.parts.empty() || setup_timings_.parts.empty()) return;
  setup_timings_.parts.pop_back();
  for (const auto& [name, seconds] : inner.parts) setup_timings_.parts.emplace_back("lowest level: " + name, seconds);
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
  if (!single_.empty()) {  // precision=single as of the last setup()
    // The cycle is linear: run it on r scaled to a largest entry of 1, so that float neither
    // overflows nor loses a residual that has fallen far below b to denormals.
    const double scale = r.size() > 0 ? r.lpNorm<Eigen::Infinity>() : 0.0;
    if (scale == 0.0) {
      z.setZero(r.size());
      return;
    }
    const double inv = std::isfinite(scale) ? 1.0 / scale : 1.0, back = std::isfinite(scale) ? scale : 1.0;
    const std::ptrdiff_t n = r.size();
    single_r_.resize(n);
#pragma omp parallel for schedule(static) if (n >= kParallelLength)
    for (std::ptrdiff_t i = 0; i < n; ++i) single_r_[i] = static_cast<float>(inv * r[i]);
    // The first cycle starts from zero and assigns single_z_.
    for (int k = 0; k < params_.cycles; ++k) cycle_single(num_levels() - 1, single_r_, single_z_, k == 0);
    z.resize(n);
#pragma omp parallel for schedule(static) if (n >= kParallelLength)
    for (std::ptrdiff_t i = 0; i < n; ++i) z[i] = back * static_cast<double>(single_z_[i]);
    return;
  }
  z.setZero(r.size());
  for (int k = 0; k < params_.cycles; ++k) cycle(num_levels() - 1, r, z, k == 0);
}

namespace {
/// y = (M ⊗ I₃) x (Add: y +=) for a scalar pattern M with float values, x and y in float.
template <bool Add>
void block_multiply_single(const CsrPattern& p, const std::vector<float>& values, const Eigen::VectorXf& x,
                           Eigen::VectorXf& y) {
  const float* v = values.data();
  const float* xp = x.data();
  float* yp = y.data();
#pragma omp parallel for schedule(static)
  for (index_t i = 0; i < p.rows; ++i) {
    float s0 = 0, s1 = 0, s2 = 0;
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
      const float w = v[k];
      const float* xj = xp + 3 * static_cast<std::ptrdiff_t>(p.col_idx[k]);
      s0 += w * xj[0], s1 += w * xj[1], s2 += w * xj[2];
    }
    float* yi = yp + 3 * static_cast<std::ptrdiff_t>(i);
    if (Add) yi[0] += s0, yi[1] += s1, yi[2] += s2;
    else yi[0] = s0, yi[1] = s1, yi[2] = s2;
  }
}

}  // namespace

void MultigridCycle::smooth_single(int l, const Eigen::VectorXf& b, Eigen::VectorXf& x, bool x_is_zero) const {
  const SingleLevel& s = single_[l];
  const std::vector<ChebyshevStep>& steps = s.smoother->steps();
  const int m = static_cast<int>(steps.size());
  const bool first_kind = s.smoother->params().kind == ChebyshevKind::first;
  Eigen::VectorXf &r = s.r, &d = s.d;
  const index_t blocks = static_cast<index_t>(b.size() / 3);
  auto residual = [&] { s.op->residual_single(b, x, r); };  // r = b - A x
  d.resize(b.size());
  int k = 0;
  if (x_is_zero) {  // r = b: the first step reads b and assigns x (no copy, no zeroing pass)
    r.resize(b.size());
    x.resize(b.size());
    chebyshev_step<float>(steps[0], true, s.inv, b.data(), nullptr, d.data(), x.data(), blocks, true);
    if (m == 1) return;
    if (first_kind) residual();
    else s.op->residual_single(b, d, r);  // r = b - A d
    k = 1;
  } else {
    residual();
  }
  for (; k < m; ++k) {
    chebyshev_step<float>(steps[k], k == 0, s.inv, r.data(), nullptr, d.data(), x.data(), blocks);
    if (k == m - 1) break;
    if (first_kind) {
      residual();
    } else {
      s.op->residual_single(r, d, r);  // r -= A d
    }
  }
}

void MultigridCycle::cycle_single(int l, const Eigen::VectorXf& b, Eigen::VectorXf& x, bool x_is_zero) const {
  if (l == 0) {  // the lowest level in double
    const auto t0 = Clock::now();
    lowest_b_ = b.cast<double>();
    lowest_->apply(lowest_b_, lowest_x_);
    x = lowest_x_.cast<float>();
    timings_.lowest_level += seconds_since(t0);
    return;
  }
  if (l == num_levels() - 1) ++timings_.cycles;
  const SingleLevel& s = single_[l];
  const BlockTransfer& T = transfers_[l - 1];
  auto t0 = Clock::now();
  smooth_single(l, b, x, x_is_zero);  // from x = 0 it sizes and assigns x
  timings_.smoothing[l] += seconds_since(t0);
  t0 = Clock::now();
  s.op->residual_single(b, x, s.r);
  timings_.residual += seconds_since(t0);
  t0 = Clock::now();
  block_multiply_single<false>(T.restriction().pattern(), s.r_values, s.r, s.rc);
  timings_.transfer += seconds_since(t0);
  // The first coarse cycle starts from zero and assigns xc (the lowest level's solve too).
  for (int g = 0; g < (l > 1 ? params_.gamma : 1); ++g) cycle_single(l - 1, s.rc, s.xc, g == 0);
  t0 = Clock::now();
  block_multiply_single<true>(T.prolongation().pattern(), s.p_values, s.xc, x);
  timings_.transfer += seconds_since(t0);
  t0 = Clock::now();
  smooth_single(l, b, x, false);
  timings_.smoothing[l] += seconds_since(t0);
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
  if (!track.start(ops::norm2(r), ops::norm2(b))) return track.finish(ops::norm2(r));
  Vector correction;
  for (int it = 1; !track.done(); ++it) {
    if (!single_.empty()) {
      apply(r, correction);  // x += C (b - A x), the cycle in float on the residual
      x += correction;
    } else {
      cycle(b, x);  // the cycle works on the full equation with x as initial guess
    }
    A.residual(b, x, r);
    const double norm = ops::norm2(r);
    // The residual here is the true one: a converged iteration is confirmed at once.
    if (track.after_iteration(it, norm) && track.accept_true_residual(norm)) break;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  return track.finish(ops::norm2(r));
}

}  // namespace pmg::mg
