#include "pmg/multigrid/chebyshev.hpp"

#include "pmg/sparse/block3.hpp"
#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace pmg::mg {

namespace {
// Lottes' optimised weights of the fourth-kind smoother, degrees 1..6 (Lottes, "Optimal polynomial
// smoothers for multigrid V-cycles", 2023, Table 1): x_k = x_(k-1) + beta_k d_(k-1).
constexpr int kMaxOptimalDegree = 6;
constexpr double kOptimalBetas[kMaxOptimalDegree][kMaxOptimalDegree] = {
    {1.12500000000000},
    {1.02387287570313, 1.26408905371085},
    {1.00842544782028, 1.08867839208730, 1.33753125909618},
    {1.00391310427285, 1.04035811188593, 1.14863498546254, 1.38268869241000},
    {1.00212930146164, 1.02173711549260, 1.07872433192603, 1.19810065292663, 1.41322542791682},
    {1.00128517255940, 1.01304293035233, 1.04678215124113, 1.11616489419675, 1.23829020218444,
     1.43524297106744},
};
}  // namespace

Chebyshev::Chebyshev(const ChebyshevParams& params) : params_(params) {
  if (params.degree < 1) throw InputError("Chebyshev: degree must be >= 1");
  if (!(params.lower_fraction > 0 && params.lower_fraction < 1))
    throw InputError("Chebyshev: lower_fraction must lie in (0, 1)");
  if (params.power_iterations < 1) throw InputError("Chebyshev: power_iterations must be >= 1");
  if (params.kind == ChebyshevKind::optimal_fourth && params.degree > kMaxOptimalDegree)
    throw InputError("Chebyshev: the optimised fourth kind is tabulated for degree <= " +
                     std::to_string(kMaxOptimalDegree));
}

Chebyshev::Chebyshev(const ChebyshevParams& params, std::unique_ptr<Solver> preconditioner)
    : Chebyshev(params) {
  if (!preconditioner) throw InputError("Chebyshev: no preconditioner");
  M_ = std::move(preconditioner);
}

void Chebyshev::setup_impl(const LinearOperator& A) {
  check_interleaved(A, "Chebyshev");
  A_ = &A;
  const Eigen::Index n = A.rows();
  r_.resize(n), d_.resize(n), z_.resize(n);
  if (M_) M_->setup(A);
  else inv_diag_ = inverse_diagonal_blocks(*A_);
  refresh_single();
  eigenvector_.resize(0);  // a new operator: no warm start
  if (params_.lanczos) estimate_lanczos();
  else estimate_power(params_.power_iterations, false);
}

namespace {
/// Chebyshev::single_range_violation() of a D⁻¹ (9 entries per block).
double range_violation(const std::vector<double>& inv_diag) {
  // Each 3x3 block's scale is its largest entry (off-diagonal ones may be rounding-small).
  const std::ptrdiff_t blocks = static_cast<std::ptrdiff_t>(inv_diag.size() / 9);
  const double* d = inv_diag.data();
  double largest = 0.0, smallest = std::numeric_limits<double>::infinity();
#pragma omp parallel for schedule(static) reduction(max : largest) reduction(min : smallest)
  for (std::ptrdiff_t b = 0; b < blocks; ++b) {
    double a = 0.0;
    for (int j = 0; j < 9; ++j) {
      const double v = std::abs(d[9 * b + j]);
      a = std::isnan(v) ? std::numeric_limits<double>::infinity() : std::max(a, v);
    }
    if (a == 0.0) continue;  // a held node
    largest = std::max(largest, a);
    smallest = std::min(smallest, a);
  }
  if (largest > Chebyshev::kSingleHigh) return largest;
  return smallest < Chebyshev::kSingleLow ? smallest : 0.0;
}
}  // namespace

void Chebyshev::refresh_single() {
  // D⁻¹ in float where a float cycle asked for it (set_single_precision), the operator applies in
  // float and D⁻¹ lies in the range float holds with margin (else empty).
  const bool wanted = !M_ && single_wanted_ && A_->single_precision_source();
  single_violation_ = wanted ? range_violation(inv_diag_) : 0.0;
  if (!wanted || single_violation_ != 0.0) {
    inv_diag_single_.clear();
    return;
  }
  inv_diag_single_.assign(inv_diag_.begin(), inv_diag_.end());
}

void Chebyshev::apply_inverse_diagonal(const Vector& r, Vector& z) const {
  if (M_) M_->apply(r, z);
  else ops::block_diagonal_apply(inv_diag_, r, z);
}

void Chebyshev::update_impl() {
  if (M_) M_->update();
  else inv_diag_ = inverse_diagonal_blocks(*A_);
  refresh_single();
  if (params_.update_iterations > 0) {
    if (eigenvector_.size() == z_.size()) estimate_power(params_.update_iterations, true);
    else estimate_power(std::max(params_.update_iterations, ChebyshevParams::kColdPowerIterations), false);
  } else if (params_.lanczos) {
    estimate_lanczos();
  } else {
    estimate_power(params_.power_iterations, false);
  }
}

namespace {
/// λmax of D⁻¹A from `steps` steps of CG on A x = r0 with the block-diagonal preconditioner D:
/// the largest eigenvalue of the Lanczos tridiagonal matrix (Saad, "Iterative Methods for Sparse
/// Linear Systems", 6.7.3) built from CG's α_k and β_k.
/// apply(p, w): w = A p; update(a, w, r, z): r += a w, z = D⁻¹ r, returning rᵀz (a = 0:
/// z = D⁻¹ r only). r: the start vector (overwritten); z, p, w: work vectors of its size, in double
/// or float (α, β and the dot products in double either way). A product or dot product that is
/// not finite (float's range exceeded) stops the steps and sets *overflow.
template <class Vec, typename Apply, typename Update>
double lanczos_lambda_max(const Apply& apply, const Update& update, Vec& r, Vec& z, Vec& p, Vec& w, int steps,
                          bool* overflow = nullptr) {
  auto finite = [&](double v) {
    if (std::isfinite(v)) return true;
    if (overflow) *overflow = true;
    return false;
  };
  double rz = update(0.0, r, r, z);
  p = z;
  std::vector<double> alpha, beta;
  for (int k = 0; k < steps && finite(rz) && rz > 0; ++k) {
    apply(p, w);
    const double pAp = ops::dot(p, w);
    if (!finite(pAp) || !(pAp > 0)) break;
    alpha.push_back(rz / pAp);
    const double rz_new = update(-alpha.back(), w, r, z);
    beta.push_back(rz_new / rz);
    ops::xpby(z, beta.back(), p);  // p = z + β p
    rz = rz_new;
  }
  const int m = static_cast<int>(alpha.size());
  if (m == 0) return 0.0;
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(m, m);
  for (int k = 0; k < m; ++k) {
    T(k, k) = 1.0 / alpha[k] + (k > 0 ? beta[k - 1] / alpha[k - 1] : 0.0);
    if (k + 1 < m) T(k, k + 1) = T(k + 1, k) = std::sqrt(std::max(beta[k], 0.0)) / alpha[k];
  }
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(T, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
}

/// v_i = 1 + sin(0.7 i) / 2: the estimates' fixed, non-smooth start, on the threads.
template <class Vec>
void start_vector(Vec& v) {
  using T = typename Vec::Scalar;
  const Eigen::Index n = v.size();
  T* x = v.data();
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < n; ++i) x[i] = static_cast<T>(1.0 + 0.5 * std::sin(0.7 * static_cast<double>(i)));
}
}  // namespace

void Chebyshev::estimate_lanczos() {
  double lambda = 0.0;
  bool overflow = false;
  if (!inv_diag_single_.empty()) {
    // An operator that applies in float: the estimate runs in float, where its products cost less
    // and its vectors half the memory traffic; λmax needs a few digits (it is raised by 10%), and
    // float's rounding moves it by about 1e-7 relative. The double work vectors stay untouched.
    // Where float's range does not hold the products (or the estimate is not positive), it runs
    // again in double.
    const SinglePrecisionSource& single = *A_->single_precision_source();
    const Eigen::Index n = z_.size();
    Eigen::VectorXf r(n), z(n), p(n), w(n);
    start_vector(r);
    lambda = lanczos_lambda_max(
        [&single](const Eigen::VectorXf& x, Eigen::VectorXf& y) { single.apply_single(x, y); },
        [this](double a, const Eigen::VectorXf& w, Eigen::VectorXf& r, Eigen::VectorXf& z) {
          return ops::block_diagonal_update_dot(a, w, inv_diag_single_, r, z);
        },
        r, z, p, w, params_.power_iterations, &overflow);
  }
  if (inv_diag_single_.empty() || overflow || !(lambda > 0.0 && std::isfinite(lambda))) {
    // The smoothing's work vectors serve (set-up allocates no more than the smoother keeps); w is
    // the one more that CG needs. With D's inverted blocks, the residual update, D⁻¹ and the dot
    // product are one pass.
    Vector w(z_.size());
    start_vector(r_);
    auto update = [this](double a, const Vector& w, Vector& r, Vector& z) {
      if (!M_) return ops::block_diagonal_update_dot(a, w, inv_diag_, r, z);
      if (a != 0.0) ops::axpy(a, w, r);
      M_->apply(r, z);
      return ops::dot(r, z);
    };
    lambda = lanczos_lambda_max([this](const Vector& x, Vector& y) { A_->apply(x, y); }, update, r_, z_, d_, w,
                                params_.power_iterations);
  }
  if (!(lambda > 0) || !std::isfinite(lambda)) throw InputError("Chebyshev: D^-1 A has no positive spectrum estimate");
  lambda_max_ = 1.1 * lambda;
  steps_ = chebyshev_steps(params_, lambda_max_);
}

void Chebyshev::estimate_power(int iterations, bool warm) {
  // Power iteration on D⁻¹A from a fixed, non-smooth start vector or the last estimate's (in
  // work vectors kept from set-up: an update per time step allocates nothing).
  Vector &v = eigenvector_, &w = r_, &z = z_;
  if (!warm || v.size() != z.size()) {
    v.resize(z.size());
    start_vector(v);
    v.normalize();
  }
  double lambda = 0.0;
  for (int k = 0; k < iterations; ++k) {
    A_->apply(v, w);
    apply_inverse_diagonal(w, z);
    lambda = ops::norm2(z);
    if (!(lambda > 0) || !std::isfinite(lambda)) throw InputError("Chebyshev: D^-1 A has no positive spectrum estimate");
    v.swap(z);  // v = z / λ, on the threads (the vectors are as long as the level)
    const double scale = 1.0 / lambda;
    const Eigen::Index n = v.size();
    double* x = v.data();
#pragma omp parallel for schedule(static)
    for (Eigen::Index i = 0; i < n; ++i) x[i] *= scale;
  }
  lambda_max_ = 1.1 * lambda;
  steps_ = chebyshev_steps(params_, lambda_max_);  // once per estimate, not per smoothing
}

void Chebyshev::pre_smooth_from_zero(const Vector& b, Vector& x) const {
  x.setZero(b.size());
  smooth(b, x, true);
}

std::vector<ChebyshevStep> chebyshev_steps(const ChebyshevParams& p, double lambda_max) {
  const int m = p.degree;
  std::vector<ChebyshevStep> steps(m);
  if (p.kind == ChebyshevKind::first) {
    const double lmax = lambda_max, lmin = p.lower_fraction * lambda_max;
    const double theta = 0.5 * (lmax + lmin), delta = 0.5 * (lmax - lmin);
    const double sigma = theta / delta;
    double rho = 1.0 / sigma;
    steps[0].c2 = 1.0 / theta;
    for (int k = 1; k < m; ++k) {
      const double rho_new = 1.0 / (2.0 * sigma - rho);
      steps[k].c1 = rho_new * rho;
      steps[k].c2 = 2.0 * rho_new / delta;
      rho = rho_new;
    }
    return steps;
  }
  if (p.kind == ChebyshevKind::optimal_fourth && (m < 1 || m > kMaxOptimalDegree))
    throw InputError("Chebyshev: the optimised fourth kind has weights for degrees 1 to " +
                     std::to_string(kMaxOptimalDegree));
  const double inv_rho = 1.0 / lambda_max;
  steps[0].c2 = (4.0 / 3.0) * inv_rho;
  for (int k = 1; k < m; ++k) {
    steps[k].c1 = static_cast<double>(2 * k - 1) / (2 * k + 3);
    steps[k].c2 = static_cast<double>(8 * k + 4) / (2 * k + 3) * inv_rho;
  }
  if (p.kind == ChebyshevKind::optimal_fourth)
    for (int k = 0; k < m; ++k) steps[k].weight = kOptimalBetas[m - 1][k];
  return steps;
}

template <class T>
void chebyshev_step(const ChebyshevStep& step, bool first, const T* inv, const T* r, const T* z, T* d, T* x,
                    index_t blocks, bool assign_x) {
  const T c1 = static_cast<T>(step.c1), c2 = static_cast<T>(step.c2), w = static_cast<T>(step.weight);
  const std::ptrdiff_t nb = blocks;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t I = 0; I < nb; ++I) {
    T zi[3];
    if (inv) block3_apply(inv + 9 * I, r + 3 * I, zi);
    else zi[0] = z[3 * I], zi[1] = z[3 * I + 1], zi[2] = z[3 * I + 2];
    for (int c = 0; c < 3; ++c) {
      T& di = d[3 * I + c];
      di = first ? c2 * zi[c] : c1 * di + c2 * zi[c];
      x[3 * I + c] = assign_x ? w * di : x[3 * I + c] + w * di;
    }
  }
}
template void chebyshev_step<double>(const ChebyshevStep&, bool, const double*, const double*, const double*,
                                     double*, double*, index_t, bool);
template void chebyshev_step<float>(const ChebyshevStep&, bool, const float*, const float*, const float*, float*,
                                    float*, index_t, bool);

// x improved in place by the polynomial of D⁻¹A (chebyshev_steps); from x = 0 the first residual is
// b itself. With the block-diagonal D⁻¹ each step is one pass over the blocks.
void Chebyshev::smooth(const Vector& b, Vector& x, bool x_is_zero) const {
  const std::vector<ChebyshevStep>& steps = steps_;
  const int m = static_cast<int>(steps.size());
  const bool first_kind = params_.kind == ChebyshevKind::first;
  if (x_is_zero) r_ = b;
  else A_->residual(b, x, r_);
  d_.resize(r_.size());
  for (int k = 0; k < m; ++k) {
    if (M_) M_->apply(r_, z_);
    chebyshev_step<double>(steps[k], k == 0, M_ ? nullptr : inv_diag_.data(), r_.data(), z_.data(), d_.data(),
                           x.data(), static_cast<index_t>(r_.size() / 3));
    if (k == m - 1) break;
    if (first_kind) {
      A_->residual(b, x, r_);
    } else {  // the residual follows the unweighted iterates: r_(k+1) = r_k - A d_k
      A_->apply(d_, z_);
      ops::axpy(-1.0, z_, r_);
    }
  }
}

}  // namespace pmg::mg
