#include "pmg/sparse/saddle_point.hpp"

#include "pmg/sparse/convergence.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

namespace pmg {

namespace {

void check_krylov_inputs(const std::string& method, const LinearOperator& K, const LinearOperator* M, const Vector& b,
                         Vector& x) {
  if (K.rows() != K.cols()) throw InputError(method + ": operator is not square");
  if (b.size() != K.rows())
    throw InputError(method + ": right-hand side has " + std::to_string(b.size()) + " entries, operator has " +
                     std::to_string(K.rows()) + " rows");
  if (M && (M->rows() != K.rows() || M->cols() != K.cols()))
    throw InputError(method + ": preconditioner size does not match the operator");
  if (x.size() != b.size()) x = Vector::Zero(b.size());
  if (!ops::all_finite(b)) throw InputError(method + ": right-hand side has NaN/Inf");
  if (!ops::all_finite(x)) throw InputError(method + ": initial guess has NaN/Inf");
}

/// The state of one Lanczos run of MINRES (Paige and Saunders; the recurrences as in SciPy's and
/// Elman–Silvester–Wathen's Algorithm 4.1), started from the residual r. Each step is one product
/// with K, one application of M, and four passes over the vectors (two of them fused: step()).
struct MinresRun {
  const LinearOperator& K;
  const LinearOperator* M;
  Eigen::Index n;
  Vector r1, r2, y, v, q, w1, w2, kw1, kw2;  // w1, w2: w_{k-2}, w_{k-1}; kw: K w alike
  double beta = 0, oldb = 0, dbar = 0, epsln = 0, phibar = 0, cs = -1, sn = 0;
  int k = 0;

  MinresRun(const LinearOperator& K_, const LinearOperator* M_, Eigen::Index n_) : K(K_), M(M_), n(n_) {
    for (Vector* u : {&r1, &r2, &y, &v, &q, &w1, &w2, &kw1, &kw2}) u->resize(n);
  }
  /// Starts from residual r; returns rᵀ M r (must be > 0).
  double start(const Vector& r) {
    r1 = r;
    r2 = r;
    if (M) M->apply(r, y);
    else y = r;
    const double b2 = ops::dot(r, y);
    beta = b2 > 0 ? std::sqrt(b2) : 0.0;
    oldb = dbar = epsln = 0;
    phibar = beta;
    cs = -1;
    sn = 0;
    w1.setZero(), w2.setZero(), kw1.setZero(), kw2.setZero();
    if (beta > 0) v = y / beta;
    k = 0;
    return b2;
  }
  /// One step: x += φ w, r -= φ K w; rr receives ||r||². Returns the new Lanczos vector's rᵀ M r
  /// (its β²; <= 0: breakdown or, when 0, an exhausted Krylov space).
  double step(Vector& x, Vector& r, double& rr) {
    ++k;
    K.apply(v, q);  // (1) q = K v
    // (2) y = q - (β/β_old) r1, α = vᵀ y: one pass over q, r1, v.
    const double c1 = k >= 2 ? beta / oldb : 0.0;
    double alfa = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : alfa) if (n > 20000)
    for (Eigen::Index i = 0; i < n; ++i) {
      const double yi = q[i] - c1 * r1[i];
      y[i] = yi;
      alfa += v[i] * yi;
    }
    ops::axpy(-alfa / beta, r2, y);  // (3) the new Lanczos vector y -= (α/β) r2
    std::swap(r1, r2);
    std::swap(r2, y);  // r1, r2: the last two Lanczos vectors; y free
    if (M) M->apply(r2, y);  // (4) y = M r2, β² = r2ᵀ y
    else y = r2;
    oldb = beta;
    const double b2 = ops::dot(r2, y);
    beta = b2 > 0 ? std::sqrt(b2) : 0.0;
    // The Givens rotation of the tridiagonal's new column.
    const double oldeps = epsln;
    const double delta = cs * dbar + sn * alfa;
    const double gbar = sn * dbar - cs * alfa;
    epsln = sn * beta;
    dbar = -cs * beta;
    const double gamma = std::max(std::hypot(gbar, beta), std::numeric_limits<double>::epsilon());  // as SciPy
    cs = gbar / gamma;
    sn = beta / gamma;
    const double phi = cs * phibar;
    phibar = sn * phibar;
    // (5) w = (v - ε w_{k-2} - δ w_{k-1}) / γ and K w = (K v - ε K w_{k-2} - δ K w_{k-1}) / γ
    // (into the storage of w_{k-2}); x += φ w; r -= φ K w; rr = rᵀ r; v = y / β for the next
    // step: one pass over 9 vectors.
    const double ig = 1.0 / gamma, ib = beta > 0 ? 1.0 / beta : 0.0;
    double sum = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : sum) if (n > 20000)
    for (Eigen::Index i = 0; i < n; ++i) {
      const double wi = (v[i] - oldeps * w1[i] - delta * w2[i]) * ig;
      const double kwi = (q[i] - oldeps * kw1[i] - delta * kw2[i]) * ig;
      w1[i] = wi;
      kw1[i] = kwi;
      x[i] += phi * wi;
      const double ri = r[i] - phi * kwi;
      r[i] = ri;
      sum += ri * ri;
      v[i] = y[i] * ib;
    }
    std::swap(w1, w2);
    std::swap(kw1, kw2);
    rr = sum;
    return b2;
  }
};

}  // namespace

SolveResult minres(const LinearOperator& K, const LinearOperator* M, const Vector& b, Vector& x,
                   const KrylovParams& params, SolveMonitor* monitor) {
  check_krylov_inputs("MINRES", K, M, b, x);
  detail::ConvergenceTracker track("MINRES", params, monitor);
  const Eigen::Index n = b.size();
  Vector r(n);
  K.residual(b, x, r);
  if (!track.start(ops::norm2(r), ops::norm2(b))) return track.finish(ops::norm2(r));
  MinresRun run(K, M, n);
  int it = 0;
  bool restart = true;
  while (restart && !track.done()) {
    restart = false;
    if (!track.check_positive(run.start(r), "r^T M^{-1} r", it)) break;
    while (!track.done()) {
      double rr = 0.0;
      const double b2 = run.step(x, r, rr);
      ++it;
      if (track.after_iteration(it, std::sqrt(rr))) {
        K.residual(b, x, r);  // the updated residual converged: confirm with the true one
        restart = !track.accept_true_residual(ops::norm2(r));
        break;
      }
      if (track.done()) break;
      if (b2 == 0.0) {  // the Krylov space is exhausted: x solves the system up to rounding
        K.residual(b, x, r);
        restart = !track.accept_true_residual(ops::norm2(r));
        break;
      }
      if (!track.check_positive(b2, "r^T M^{-1} r", it)) break;
    }
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  K.residual(b, x, r);
  return track.finish(ops::norm2(r));
}

// ---- GMRES -------------------------------------------------------------------------------------------

namespace {

constexpr Eigen::Index kChunk = 2048;  // entries of a pass's block: the block of w stays in cache

/// h[i] = A[i]·w for i < ma and h[ma + i] = B[i]·w for i < mb, in one pass over the vectors (blocks
/// of w, each against every vector). Each block's dot products are ops::dot_serial and the blocks'
/// sums are added in order: the same bits on any number of threads.
template <class VA, class VB>
void fused_dots(const std::vector<VA>& A, int ma, const std::vector<VB>& B, int mb, const Vector& w, double* h) {
  const Eigen::Index n = w.size();
  const Eigen::Index blocks = (n + kChunk - 1) / kChunk;
  const int m = ma + mb;
  std::vector<double> part(static_cast<size_t>(blocks * m));
#pragma omp parallel for schedule(static)
  for (Eigen::Index q = 0; q < blocks; ++q) {
    const Eigen::Index k0 = q * kChunk, len = std::min(n, k0 + kChunk) - k0;
    double* out = part.data() + q * m;
    for (int i = 0; i < ma; ++i) out[i] = ops::dot_serial(A[static_cast<size_t>(i)].data() + k0, w.data() + k0, len);
    for (int i = 0; i < mb; ++i)
      out[ma + i] = ops::dot_serial(B[static_cast<size_t>(i)].data() + k0, w.data() + k0, len);
  }
  for (int i = 0; i < m; ++i) {
    double sum = 0.0;
    for (Eigen::Index q = 0; q < blocks; ++q) sum += part[static_cast<size_t>(q * m + i)];
    h[i] = sum;
  }
}

/// w -= Σ_{i<ma} h[i] A[i] + Σ_{i<mb} h[ma + i] B[i] (sign = -1), or w += the same (sign = +1), in
/// one pass, in double for vectors in double or float; returns ‖w‖ after it (its blocks' sums of
/// squares added in order).
template <class VA, class VB>
double fused_update(const std::vector<VA>& A, int ma, const std::vector<VB>& B, int mb, const double* h, Vector& w,
                    double sign) {
  const Eigen::Index n = w.size();
  const Eigen::Index blocks = (n + kChunk - 1) / kChunk;
  std::vector<double> part(static_cast<size_t>(blocks));
  auto add = [&w, sign](const auto* v, double hi, Eigen::Index k0, Eigen::Index k1) {
    const double c = sign * hi;
    for (Eigen::Index k = k0; k < k1; ++k) w[k] += c * static_cast<double>(v[k]);
  };
#pragma omp parallel for schedule(static)
  for (Eigen::Index q = 0; q < blocks; ++q) {
    const Eigen::Index k0 = q * kChunk, k1 = std::min(n, k0 + kChunk);
    for (int i = 0; i < ma; ++i) add(A[static_cast<size_t>(i)].data(), h[i], k0, k1);
    for (int i = 0; i < mb; ++i) add(B[static_cast<size_t>(i)].data(), h[ma + i], k0, k1);
    part[static_cast<size_t>(q)] = ops::dot_serial(w.data() + k0, w.data() + k0, k1 - k0);
  }
  double sq = 0.0;
  for (Eigen::Index q = 0; q < blocks; ++q) sq += part[static_cast<size_t>(q)];
  return std::sqrt(sq);
}

/// fused_update() over one list.
template <class VA>
double fused_update(const std::vector<VA>& A, int m, const double* h, Vector& w, double sign) {
  static const std::vector<Eigen::VectorXf> none;
  return fused_update(A, m, none, 0, h, w, sign);
}

/// dst = scale * src, in parallel.
void scaled_copy(const Vector& src, double scale, Vector& dst) {
  const Eigen::Index n = src.size();
  dst.resize(n);
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < n; ++k) dst[k] = scale * src[k];
}

template <class VectorType>
void grow(std::vector<VectorType>& V, size_t count, Eigen::Index n) {
  while (V.size() < count) V.emplace_back(n);
}

/// The Krylov basis of one GMRES cycle: its first `doubles` vectors in double (ws.V), the rest in
/// float (ws.Vf; GmresParams::float_basis).
class Basis {
 public:
  /// Vectors of another size than n in the workspace are of no use: dropped.
  Basis(GmresWorkspace& ws, Eigen::Index n) : V_(ws.V), Vf_(ws.Vf), exact_(ws.v), n_(n) {
    if (!V_.empty() && V_.front().size() != n) V_.clear();
    if (!Vf_.empty() && Vf_.front().size() != n) Vf_.clear();
  }
  /// A new cycle: vectors in double until switch_to_float().
  void restart() { doubles_ = std::numeric_limits<int>::max(); }
  /// Vectors from i on are stored in float.
  void switch_to_float(int i) { doubles_ = std::min(doubles_, i); }
  /// Whether this cycle stored a vector in float so far (given its count of vectors).
  bool used_float(int count) const { return count > doubles_; }
  /// v_i = scale * src (i: the next index), rounded to float from doubles_ on; a float v_i is kept
  /// in double too, as the next product's input, so that z_i = M v_i holds for the stored v_i.
  void store(int i, const Vector& src, double scale) {
    if (i < doubles_) {
      grow(V_, static_cast<size_t>(i) + 1, n_);
      scaled_copy(src, scale, V_[static_cast<size_t>(i)]);
      return;
    }
    grow(Vf_, static_cast<size_t>(i - doubles_) + 1, n_);
    float* dst = Vf_[static_cast<size_t>(i - doubles_)].data();
    exact_.resize(n_);
    double* exact = exact_.data();
    const double* s = src.data();
#pragma omp parallel for schedule(static)
    for (Eigen::Index k = 0; k < n_; ++k) {
      const float f = static_cast<float>(scale * s[k]);
      dst[k] = f;
      exact[k] = static_cast<double>(f);
    }
  }
  /// v_i in double (i: the newest index).
  const Vector& operator[](int i) const { return i < doubles_ ? V_[static_cast<size_t>(i)] : exact_; }
  /// h = V_mᵀ w, the first m vectors.
  void dots(int m, const Vector& w, double* h) const {
    const int md = std::min(m, doubles_);
    fused_dots(V_, md, Vf_, m - md, w, h);
  }
  /// w += sign V_m h; returns ‖w‖.
  double update(int m, const double* h, Vector& w, double sign) const {
    const int md = std::min(m, doubles_);
    return fused_update(V_, md, Vf_, m - md, h, w, sign);
  }

 private:
  std::vector<Vector>& V_;
  std::vector<Eigen::VectorXf>& Vf_;
  Vector& exact_;
  Eigen::Index n_;
  int doubles_ = std::numeric_limits<int>::max();
};

/// dst = src in float (src exact in float: PreconditionedProduct::single_precision).
void store_single(const Vector& src, Eigen::VectorXf& dst) {
  const Eigen::Index n = src.size();
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < n; ++k) dst[k] = static_cast<float>(src[k]);
}

/// f(k) for k < n, split statically over the threads.
template <class F>
void parallel_for(Eigen::Index n, const F& f) {
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < n; ++k) f(k);
}

/// v rounded to the nearest float, in place.
void round_to_float(Vector& v) {
  const Eigen::Index n = v.size();
#pragma omp parallel for schedule(static) if (n > 20000)
  for (Eigen::Index k = 0; k < n; ++k) v[k] = static_cast<double>(static_cast<float>(v[k]));
}

/// z = M v, then w = K z.
class ComposedProduct final : public PreconditionedProduct {
 public:
  ComposedProduct(const LinearOperator& K, const LinearOperator& M) : K_(K), M_(M) {}
  void apply(const Vector& v, Vector& z, Vector& w) const override {
    M_.apply(v, z);
    K_.apply(z, w);
  }

 private:
  const LinearOperator &K_, &M_;
};

/// gmres() with KM (nullptr: no preconditioner), its inputs checked.
SolveResult gmres_run(const LinearOperator& K, const PreconditionedProduct* KM, const Vector& b, Vector& x,
                      const KrylovParams& params, const GmresParams& options, SolveMonitor* monitor,
                      GmresWorkspace* work) {
  if (options.restart < 1) throw InputError("GMRES: restart must be >= 1, got " + std::to_string(options.restart));
  GmresWorkspace own;
  GmresWorkspace& ws = work ? *work : own;
  std::vector<Vector>& Z = ws.Z;  // M v_i (flexible GMRES)
  std::vector<Eigen::VectorXf>& Zf = ws.Zf;  // the same in float, where the product's z are exact in float
  const bool single = KM && KM->single_precision();
  detail::ConvergenceTracker track("GMRES", params, monitor);
  const Eigen::Index n = b.size();
  // Vectors of another size are of no use.
  auto keep_if_sized = [n](auto& vs) {
    if (!vs.empty() && vs.front().size() != n) vs.clear();
  };
  keep_if_sized(Z), keep_if_sized(Zf);
  Basis V(ws, n);
  Vector& r = ws.r;
  Vector& w = ws.w;
  r.resize(n), w.resize(n);
  K.residual(b, x, r);
  if (!track.start(ops::norm2(r), ops::norm2(b))) return track.finish(ops::norm2(r));
  // A float basis vector v_{i+1} perturbs the Arnoldi relation by about float's rounding u times
  // its column, which moves the final residual by about u times the residual when it was stored
  // (the later vectors of GMRES's solution carry coefficients of the size of the residual then:
  // the argument of inexact Krylov methods, Simoncini and Szyld 2003). So vectors are stored in
  // float once 100 u times the estimated residual is below the target; the true residual decides
  // convergence either way. Where the coefficients are large (an ill-conditioned Hessenberg matrix,
  // which the bound's constant hides) the true residual of a cycle with float vectors can miss its
  // estimate: then the rest of the solve keeps its vectors in double.
  bool float_allowed = options.float_basis;
  const double target =
      params.fixed_iterations ? 0.0 : std::max(params.rel_tol * track.r0(), params.abs_tol);
  constexpr double kFloatRounding = 0x1p-24;
  const int m = options.restart;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m + 1, m);
  Eigen::VectorXd g(m + 1), cs(m), sn(m), h(m + 1), h2(m + 1);
  int it = 0;
  while (!track.done()) {
    const double beta = ops::norm2(r);
    if (beta == 0.0) {  // x solves the system exactly (a cycle ended on it)
      track.accept_true_residual(0.0);
      break;
    }
    V.restart();
    if (float_allowed && 100.0 * kFloatRounding * beta <= target) V.switch_to_float(0);
    V.store(0, r, 1.0 / beta);
    g.setZero();
    g[0] = beta;
    int j = 0;
    bool converged = false;
    for (; j < m && !track.done();) {
      const auto jj = static_cast<size_t>(j);
      if (single) {
        KM->apply(V[j], ws.z, w);
        grow(Zf, jj + 1, n);
        store_single(ws.z, Zf[jj]);
      } else if (KM) {
        grow(Z, jj + 1, n);
        KM->apply(V[j], Z[jj], w);
      } else {
        K.apply(V[j], w);
      }
      // Classical Gram–Schmidt: once, or twice where the first pass lost more than 30% of ‖w‖.
      const double before = options.reorthogonalise ? ops::norm2(w) : 0.0;
      V.dots(j + 1, w, h.data());
      double after = V.update(j + 1, h.data(), w, -1.0);
      if (options.reorthogonalise && after < 0.7 * before) {
        V.dots(j + 1, w, h2.data());
        after = V.update(j + 1, h2.data(), w, -1.0);
        h.head(j + 1) += h2.head(j + 1);
      }
      H.col(j).head(j + 1) = h.head(j + 1);
      H(j + 1, j) = after;
      // The Givens rotations of the columns before, then this column's own.
      for (int i = 0; i < j; ++i) {
        const double a = H(i, j), c = H(i + 1, j);
        H(i, j) = cs[i] * a + sn[i] * c;
        H(i + 1, j) = -sn[i] * a + cs[i] * c;
      }
      const double rho = std::hypot(H(j, j), H(j + 1, j));
      cs[j] = rho > 0 ? H(j, j) / rho : 1.0;
      sn[j] = rho > 0 ? H(j + 1, j) / rho : 0.0;
      H(j, j) = rho;
      H(j + 1, j) = 0.0;
      g[j + 1] = -sn[j] * g[j];
      g[j] = cs[j] * g[j];
      if (float_allowed && 100.0 * kFloatRounding * std::abs(g[j + 1]) <= target) V.switch_to_float(j + 1);
      if (after > 0) V.store(j + 1, w, 1.0 / after);
      ++j, ++it;
      if (track.after_iteration(it, std::abs(g[j]))) {
        converged = true;
        break;
      }
      if (after == 0.0 || !(rho > 0)) break;  // the Krylov space is exhausted (or singular): form x
    }
    if (j > 0) {
      // y = R⁻¹ g (R the rotated upper triangle), x += Z y (V y without M).
      Eigen::VectorXd y = g.head(j);
      for (int i = j - 1; i >= 0; --i) {
        for (int k = i + 1; k < j; ++k) y[i] -= H(i, k) * y[k];
        y[i] = H(i, i) != 0 ? y[i] / H(i, i) : 0.0;
      }
      if (single) fused_update(Zf, j, y.data(), x, 1.0);
      else if (KM) fused_update(Z, j, y.data(), x, 1.0);
      else V.update(j, y.data(), x, 1.0);
    }
    // Converged: the true residual confirms it, or the next cycle starts from it (as at a restart,
    // or after an exhausted Krylov space).
    K.residual(b, x, r);
    const double true_norm = ops::norm2(r);
    if (j > 0 && V.used_float(j + 1) && true_norm > std::max(1.1 * std::abs(g[j]), target)) {
      // The float vectors cost this cycle its estimate: the next cycles keep theirs in double, and
      // a converged estimate is not taken on trust (the next cycle starts from x).
      float_allowed = false;
      continue;
    }
    if (converged && track.accept_true_residual(true_norm)) break;
  }
  if (track.result().ok()) return track.finish(std::numeric_limits<double>::quiet_NaN());
  return track.finish(ops::norm2(r));
}

}  // namespace

SolveResult gmres(const LinearOperator& K, const LinearOperator* M, const Vector& b, Vector& x,
                  const KrylovParams& params, const GmresParams& options, SolveMonitor* monitor, GmresWorkspace* work) {
  check_krylov_inputs("GMRES", K, M, b, x);
  if (!M) return gmres_run(K, nullptr, b, x, params, options, monitor, work);
  const ComposedProduct KM(K, *M);
  return gmres_run(K, &KM, b, x, params, options, monitor, work);
}

SolveResult gmres(const LinearOperator& K, const PreconditionedProduct& KM, const Vector& b, Vector& x,
                  const KrylovParams& params, const GmresParams& options, SolveMonitor* monitor, GmresWorkspace* work) {
  check_krylov_inputs("GMRES", K, nullptr, b, x);
  return gmres_run(K, &KM, b, x, params, options, monitor, work);
}

// ---- Gmres -----------------------------------------------------------------------------------------

Gmres::Gmres(const KrylovParams& params, std::unique_ptr<Solver> preconditioner, const GmresParams& options)
    : PreconditionedKrylov(params, std::move(preconditioner)), options_(options) {
  if (options.restart < 1) throw InputError("GMRES: restart must be >= 1, got " + std::to_string(options.restart));
}

std::string Gmres::describe() const {
  const std::string m = !M_ ? "no preconditioner" : (M_->describe().empty() ? M_->name() : M_->describe());
  return "GMRES(" + std::to_string(options_.restart) + "), " + m;
}

SolveResult Gmres::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  return gmres(system(), M_.get(), b, x, with_rhs_floor(params_, b), options_, monitor, &work_);
}

// ---- BlockTriangularOperator -----------------------------------------------------------------------

BlockTriangularOperator::BlockTriangularOperator(const LinearOperator& M_u, const LinearOperator& M_p,
                                                 const SaddlePointCoupling& B)
    : M_u_(M_u), M_p_(M_p), B_(B) {
  if (M_u.rows() != M_u.cols() || M_p.rows() != M_p.cols())
    throw InputError("block triangular operator: both blocks must be square");
  if (B.rows() != M_p.rows() || B.cols() != M_u.rows())
    throw InputError("block triangular operator: B is " + std::to_string(B.rows()) + " x " + std::to_string(B.cols()) +
                     " for blocks of " + std::to_string(M_u.rows()) + " and " + std::to_string(M_p.rows()));
}

void BlockTriangularOperator::precondition(const Vector& v, bool single) const {
  const index_t nu = M_u_.rows(), np = M_p_.rows();
  rp_ = v.tail(np);
  M_p_.apply(rp_, zp_);  // z_p = -M_p r_p, so r_u - Bᵀ z_p = r_u + Bᵀ (M_p r_p)
  if (single) round_to_float(zp_);
  bt_.resize(nu), ru_.resize(nu);
  double* bt = bt_.data();
  parallel_for(nu, [bt](Eigen::Index k) { bt[k] = 0.0; });
  B_.apply(nullptr, zp_.data(), bt, nullptr);
  parallel_for(nu, [&](Eigen::Index k) { ru_[k] = v[k] + bt[k]; });
  M_u_.apply(ru_, zu_);
  if (single) round_to_float(zu_);
}

void BlockTriangularOperator::apply_impl(const Vector& x, Vector& y) const {
  const index_t nu = M_u_.rows(), np = M_p_.rows();
  precondition(x, false);
  y.resize(nu + np);
  y.head(nu) = zu_;
  y.tail(np) = -zp_;
}

void BlockTriangularOperator::apply_and_multiply(const SaddlePointOperator& K, const Vector& v, Vector& z,
                                                 Vector& w, bool round_to_float) const {
  const index_t nu = M_u_.rows(), np = M_p_.rows();
  if (&K.coupling() != &B_ || K.rows() != rows())
    throw InputError("block triangular operator: the saddle point's coupling or size is not the preconditioner's");
  if (v.size() != rows())
    throw InputError("block triangular operator: a vector of " + std::to_string(v.size()) + " entries for " +
                     std::to_string(rows()) + " rows");
  precondition(v, round_to_float);
  z.resize(nu + np);
  parallel_for(nu, [&](Eigen::Index k) { z[k] = zu_[k]; });
  z.tail(np) = -zp_;
  // w_u = A z_u + Bᵀ z_p = A z_u − bt_; w_p = B z_u − C z_p = B z_u + C zp_.
  w.resize(nu + np);
  wu_.resize(nu);
  K.first_block().apply(zu_, wu_);
  parallel_for(nu, [&](Eigen::Index k) { w[k] = wu_[k] - bt_[k]; });
  B_.apply(zu_.data(), nullptr, nullptr, w.data() + nu);
  if (const Csr* C = K.second_block()) {
    cp_.resize(np);
    C->multiply(zp_.data(), cp_.data());
    w.tail(np) += cp_;
  }
}

BlockTriangularProduct::BlockTriangularProduct(const BlockTriangularOperator& P, const SaddlePointOperator& K,
                                               bool single_precision)
    : P_(P), K_(K), single_(single_precision) {
  if (K.rows() != P.rows())
    throw InputError("block triangular product: the saddle point has " + std::to_string(K.rows()) +
                     " rows, the preconditioner " + std::to_string(P.rows()));
}

// ---- SaddlePointOperator ---------------------------------------------------------------------------

CsrCoupling::CsrCoupling(const Csr& B, const Csr& Bt) : B_(B), Bt_(Bt) {
  if (Bt.rows() != B.cols() || Bt.cols() != B.rows())
    throw InputError("saddle point: B is " + std::to_string(B.rows()) + " x " + std::to_string(B.cols()) +
                     " and Bᵀ " + std::to_string(Bt.rows()) + " x " + std::to_string(Bt.cols()));
}

void CsrCoupling::apply(const double* x_u, const double* x_p, double* y_u, double* y_p) const {
  if (x_u) B_.multiply(x_u, y_p);
  if (!x_p) return;
  const CsrPattern& p = Bt_.pattern();
  const double* v = Bt_.values().data();
#pragma omp parallel for schedule(static)
  for (index_t i = 0; i < p.rows; ++i) {
    double sum = 0.0;
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) sum += v[k] * x_p[p.col_idx[k]];
    y_u[i] += sum;
  }
}

SaddlePointOperator::SaddlePointOperator(const LinearOperator& A, const SaddlePointCoupling& B, const Csr* C)
    : A_(A), B_(B), C_(C), n_u_(A.rows()), n_p_(B.rows()) {
  if (A.rows() != A.cols()) throw InputError("saddle point: A is not square");
  if (B.cols() != n_u_)
    throw InputError("saddle point: B has " + std::to_string(B.cols()) + " columns for A of " + std::to_string(n_u_) +
                     " rows");
  if (C && (C->rows() != n_p_ || C->cols() != n_p_))
    throw InputError("saddle point: C must be " + std::to_string(n_p_) + " x " + std::to_string(n_p_));
}

void SaddlePointOperator::apply_impl(const Vector& x, Vector& y) const {
  // y_u = A x_u + Bᵀ x_p, y_p = B x_u - C x_p; A takes Vectors, so x_u and y_u are copied once.
  xu_ = x.head(n_u_);
  yu_.resize(n_u_);
  A_.apply(xu_, yu_);
  y.resize(rows());
  B_.apply(x.data(), x.data() + n_u_, yu_.data(), y.data() + n_u_);
  y.head(n_u_) = yu_;
  if (C_) {
    cp_.resize(n_p_);
    C_->multiply(x.data() + n_u_, cp_.data());
    y.tail(n_p_) -= cp_;
  }
}

// ---- BlockDiagonalOperator -------------------------------------------------------------------------

BlockDiagonalOperator::BlockDiagonalOperator(const LinearOperator& first, const LinearOperator& second)
    : first_(first), second_(second) {
  if (first.rows() != first.cols() || second.rows() != second.cols())
    throw InputError("block diagonal operator: both blocks must be square");
}

void BlockDiagonalOperator::apply_impl(const Vector& x, Vector& y) const {
  const index_t n1 = first_.rows(), n2 = second_.rows();
  x1_ = x.head(n1);
  x2_ = x.tail(n2);
  y1_.resize(n1), y2_.resize(n2);
  first_.apply(x1_, y1_);
  second_.apply(x2_, y2_);
  y.resize(n1 + n2);
  y.head(n1) = y1_;
  y.tail(n2) = y2_;
}

// ---- ChebyshevMassInverse --------------------------------------------------------------------------

ChebyshevMassInverse::ChebyshevMassInverse(const Csr& M, double lo, double hi, int steps, double scale)
    : M_(M), lo_(lo), hi_(hi), scale_(scale), steps_(steps) {
  if (M.rows() != M.cols()) throw InputError("Chebyshev mass inverse: the matrix is not square");
  if (steps < 1) throw InputError("Chebyshev mass inverse: steps must be >= 1");
  if (!(lo > 0.0 && hi > lo && std::isfinite(hi)))
    throw InputError("Chebyshev mass inverse: bounds must satisfy 0 < lo < hi");
  if (!(scale > 0.0 && std::isfinite(scale))) throw InputError("Chebyshev mass inverse: scale must be > 0");
  const Vector d = M.diagonal();
  inv_diag_.resize(d.size());
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    if (!(d[i] > 0.0 && std::isfinite(d[i])))
      throw InputError("Chebyshev mass inverse: diagonal entry " + std::to_string(i) + " is not positive");
    inv_diag_[i] = 1.0 / d[i];
  }
  values_.assign(M.values().begin(), M.values().end());
}

void ChebyshevMassInverse::apply_impl(const Vector& r, Vector& z) const {
  // Saad, "Iterative methods for sparse linear systems", Algorithm 12.1, on D⁻¹M: each step is
  // res -= M d, d ← c₁ d + c₂ D⁻¹ res, z += d, fused into one pass over the rows (d double-buffered).
  const double theta = 0.5 * (hi_ + lo_), delta = 0.5 * (hi_ - lo_);
  const double sigma = theta / delta;
  const CsrPattern& p = M_.pattern();
  const offset_t* rp = p.row_ptr.data();
  const index_t* ci = p.col_idx.data();
  const float* v = values_.data();
  const index_t n = p.rows;
  res_.resize(n), d_.resize(n), d_next_.resize(n), z.resize(n);
  double* res = res_.data();
  double* zp = z.data();
  const double* inv = inv_diag_.data();
  const double last = steps_ == 1 ? scale_ : 1.0;
#pragma omp parallel if (n > 4096)
  {
    double* d = d_.data();
    double* dn = d_next_.data();
#pragma omp for schedule(static)
    for (index_t i = 0; i < n; ++i) {
      res[i] = r[i];
      d[i] = inv[i] * r[i] / theta;
      zp[i] = last * d[i];
    }
    double rho = 1.0 / sigma;
    for (int k = 2; k <= steps_; ++k) {
      const double rho_new = 1.0 / (2.0 * sigma - rho);
      const double c1 = rho_new * rho, c2 = 2.0 * rho_new / delta;
      const double s = k == steps_ ? scale_ : 1.0;
#pragma omp for schedule(static)
      for (index_t i = 0; i < n; ++i) {
        // Four partial sums over the row: independent chains of additions.
        double q4[4] = {};
        offset_t e = rp[i];
        for (; e + 4 <= rp[i + 1]; e += 4)
          for (int l = 0; l < 4; ++l) q4[l] += static_cast<double>(v[e + l]) * d[ci[e + l]];
        for (int l = 0; e < rp[i + 1]; ++e, ++l) q4[l] += static_cast<double>(v[e]) * d[ci[e]];
        const double ri = res[i] - ((q4[0] + q4[2]) + (q4[1] + q4[3]));
        res[i] = ri;
        const double di = c1 * d[i] + c2 * inv[i] * ri;
        dn[i] = di;
        zp[i] = s * (zp[i] + di);
      }  // the barrier: every d read before any is overwritten in the next step
      std::swap(d, dn);
      rho = rho_new;
    }
  }
}

}  // namespace pmg

// ---- MixedKrylov -----------------------------------------------------------------------------------

namespace pmg {

void MixedKrylovParams::visit(ParamVisitor& v) {
  v.integer("pressure_steps", pressure_steps, 1, 1000,
            "Chebyshev steps on the pressure mass matrix (the Schur complement's approximation)");
  v.real("pressure_scale", pressure_scale, 1e-6, 1e6,
         "factor of the Schur complement's approximation (1/mu + 1/lambda) M_p");
}

void GmresParams::visit(ParamVisitor& v) {
  v.integer("restart", restart, 1, 10000,
            "Krylov vectors kept before GMRES restarts (memory: restart + 1 basis vectors, in float once the "
            "residual nears the target (float_basis), and restart preconditioned ones, in float for mixed-gmres)");
  v.boolean("reorthogonalise", reorthogonalise,
            "repeat classical Gram-Schmidt where it lost more than 30% of the norm (else one pass)");
  v.boolean("float_basis", float_basis,
            "store Krylov vectors in float once the estimated residual is below 1.7e5 times the target, the "
            "arithmetic in double (half their memory and Gram-Schmidt traffic; the true residual decides convergence)");
}

MixedKrylov::MixedKrylov(Kind kind, const KrylovParams& params, std::unique_ptr<Solver> displacement,
                         const SaddlePointBlocks& blocks, const MixedKrylovParams& mixed, const GmresParams& gmres)
    : kind_(kind), params_(params), M_u_(std::move(displacement)), blocks_(&blocks), mixed_(mixed), gmres_(gmres) {
  const std::string me = name();
  if (!M_u_) throw InputError(me + ": no solver for the displacement block");
  if (!M_u_->is_linear() || !M_u_->is_symmetric())
    throw InputError(me + ": the displacement block's solver '" + M_u_->name() +
                     "' is not a fixed symmetric map; the block preconditioner needs one (a multigrid cycle with "
                     "R = Pᵀ)");
  if (!blocks.coupling || !blocks.pressure_mass)
    throw InputError(me + ": the saddle-point blocks (B and Bᵀ, pressure mass) were not given");
  if (mixed.pressure_steps < 1) throw InputError(me + ": pressure_steps must be >= 1");
  if (gmres.restart < 1) throw InputError(me + ": restart must be >= 1");
}

std::string MixedKrylov::describe() const {
  std::ostringstream scale;
  scale << mixed_.pressure_scale * blocks_->schur_scale;
  return (kind_ == Kind::minres ? "MINRES, block-diagonal preconditioner: displacement "
                                : "GMRES(" + std::to_string(gmres_.restart) + (gmres_.reorthogonalise ? "" : ", one Gram-Schmidt pass") + ", z_i in float), block-triangular preconditioner: displacement ") +
         (M_u_->describe().empty() ? M_u_->name() : M_u_->describe()) + "; pressure " +
         std::to_string(mixed_.pressure_steps) + " Chebyshev steps on the mass, S ~ " + scale.str() + " M_p";
}

void MixedKrylov::setup_impl(const LinearOperator& K) {
  const SaddlePointOperator* sp = K.saddle_point_operator();
  if (!sp) throw InputError(name() + ": the system is not a saddle-point operator [A Bᵀ; B -C]");
  if (&sp->coupling() != blocks_->coupling || sp->second_block() != blocks_->C)
    throw InputError(name() + ": the system's blocks are not those the solver was built for");
  M_u_->setup(sp->first_block());
  set_up_pressure();
}

void MixedKrylov::set_up_pressure() {
  // The Schur scale is read afresh: the blocks' weights may have changed (a time step's).
  M_p_ = std::make_unique<ChebyshevMassInverse>(*blocks_->pressure_mass, blocks_->mass_lo, blocks_->mass_hi,
                                                mixed_.pressure_steps,
                                                1.0 / (mixed_.pressure_scale * blocks_->schur_scale));
  if (kind_ == Kind::minres) P_ = std::make_unique<BlockDiagonalOperator>(*M_u_, *M_p_);
  else {
    auto P = std::make_unique<BlockTriangularOperator>(*M_u_, *M_p_, *blocks_->coupling);
    triangular_ = P.get();
    P_ = std::move(P);
  }
}

void MixedKrylov::update_impl() {
  M_u_->update();
  set_up_pressure();
}

SolveResult MixedKrylov::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  if (kind_ == Kind::minres) return minres(system(), P_.get(), b, x, with_rhs_floor(params_, b), monitor);
  const SaddlePointOperator& K = *system().saddle_point_operator();
  const BlockTriangularProduct KP(*triangular_, K, /*single_precision=*/true);
  return gmres(K, KP, b, x, with_rhs_floor(params_, b), gmres_, monitor, &work_);
}

void MixedKrylov::apply_impl(const Vector& b, Vector& x) const {
  x.setZero();
  require_usable(solve_impl(b, x, nullptr));
}

}  // namespace pmg
