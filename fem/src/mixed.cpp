#include "pmg/fem/mixed.hpp"

#include "pmg/sparse/config.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/timer.hpp"

#include <Eigen/Eigenvalues>

#include <array>
#include <cmath>
#include <mutex>

#include <omp.h>

namespace pmg::fem {

namespace {

MixedTables build_mixed_tables(int k) {
  MixedTables t;
  t.k = k;
  t.nu = num_element_nodes(k);
  t.np = num_element_nodes(k - 1);
  const auto& au = multi_indices(k);
  const auto& ap = multi_indices(k - 1);
  t.D.assign(static_cast<size_t>(t.np) * t.nu * 4, 0.0);
  for (int b = 0; b < t.np; ++b)
    for (int a = 0; a < t.nu; ++a)
      for (int i = 0; i < 4; ++i) {
        if (au[a][i] == 0) continue;
        MultiIndex lower = au[a];
        --lower[i];
        t.D[(static_cast<size_t>(b) * t.nu + a) * 4 + i] = k * bernstein_product_integral(ap[b], lower);
      }
  // Spectrum of D_e⁻¹ M_e = that of D_e^{-1/2} M_e D_e^{-1/2} (Wathen 1987: it bounds the global one).
  const Eigen::MatrixXd& M = element_tables(k - 1).mass;
  const Eigen::VectorXd s = M.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd S = s.asDiagonal() * M * s.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S);
  t.mass_lo = eig.eigenvalues().minCoeff();
  t.mass_hi = eig.eigenvalues().maxCoeff();
  return t;
}

}  // namespace

const MixedTables& mixed_tables(int k) {
  if (k != 2 && k != 3)
    throw InputError("mixed elements: the displacement degree must be 2 or 3 (Taylor–Hood needs a pressure of "
                     "degree k - 1 >= 1), got " + std::to_string(k));
  static std::once_flag once[2];
  static MixedTables tables[2];
  std::call_once(once[k - 2], [k] { tables[k - 2] = build_mixed_tables(k); });
  return tables[k - 2];
}

void element_divergence(const MixedTables& t, const ElementGeometry& g, Eigen::MatrixXd& Be) {
  Be.setZero(t.np, 3 * t.nu);
  const double v6 = 6.0 * g.volume;
  for (int b = 0; b < t.np; ++b)
    for (int a = 0; a < t.nu; ++a) {
      const double* d = &t.D[(static_cast<size_t>(b) * t.nu + a) * 4];
      for (int c = 0; c < 3; ++c)
        Be(b, 3 * a + c) = v6 * (d[0] * g.grad(0, c) + d[1] * g.grad(1, c) + d[2] * g.grad(2, c) + d[3] * g.grad(3, c));
    }
}

void check_mixed_material(const Material& m) {
  if (!std::isfinite(m.young) || !(m.young > 0))
    throw InputError("material: Young's modulus must be a positive number, got " + std::to_string(m.young));
  if (!std::isfinite(m.poisson) || !(m.poisson > 0.0 && m.poisson <= 0.5))
    throw InputError("material: Poisson's ratio must lie in (0, 0.5] for the mixed formulation (λ > 0: the "
                     "pressure is λ div u), got " + std::to_string(m.poisson) +
                     "; at ν <= 0 the displacement formulation does not lock");
  if (!std::isfinite(m.density) || m.density < 0)
    throw InputError("material: density must be >= 0, got " + std::to_string(m.density));
}

Material MixedElasticity::shear_material(const Material& m) {
  Material s = m;
  s.young = 2.0 * m.mu();
  s.poisson = 0.0;
  return s;
}

namespace {
/// The material, checked before any level is built (InputError otherwise).
const Material& checked(const Material& m) {
  check_mixed_material(m);
  return m;
}
/// The degree, checked before any level is built (InputError otherwise).
int checked_degree(int k) {
  mixed_tables(k);
  return k;
}
}  // namespace

MixedElasticity::MixedElasticity(const TetMesh& mesh, int degree, const Material& material, std::vector<char> clamped,
                                 std::vector<char> components)
    : material_(checked(material)),
      owned_(std::make_unique<DegreeHierarchy>(mesh, checked_degree(degree), shear_material(material),
                                               std::move(clamped), std::move(components))),
      hierarchy_(owned_.get()),
      pressure_(mesh, degree - 1),
      lambda_inverse_(material.poisson == 0.5 ? 0.0 : 1.0 / material.lambda()) {
  assemble_pressure_mass();
}

namespace {
/// The hierarchy, checked to be the displacement levels of `material` (InputError otherwise).
DegreeHierarchy& shear_levels(const Material& material, DegreeHierarchy& h) {
  const Material& m = h.finest().material();
  const Material s = MixedElasticity::shear_material(checked(material));
  if (m.young != s.young || m.poisson != s.poisson || m.density != s.density)
    throw InputError("mixed elements: the displacement hierarchy must be built on the shear material (E' = 2μ, "
                     "ν' = 0) of the mixed material");
  checked_degree(h.num_levels());
  return h;
}
}  // namespace

MixedElasticity::MixedElasticity(const Material& material, DegreeHierarchy& hierarchy)
    : material_(material),
      hierarchy_(&shear_levels(material, hierarchy)),
      pressure_(hierarchy.finest().space().mesh(), hierarchy.num_levels() - 1),
      lambda_inverse_(material.poisson == 0.5 ? 0.0 : 1.0 / material.lambda()) {
  assemble_pressure_mass();
}

DivergenceCoupling::DivergenceCoupling(const ElasticityModel& u, const BBSpace& pressure) : u_(u), pressure_(pressure) {
  const int k = u.space().degree();
  if ((k != 2 && k != 3) || pressure.degree() != k - 1 || &pressure.mesh() != &u.space().mesh())
    throw InputError("divergence coupling: needs displacement of degree 2 or 3 and a pressure of one degree less "
                     "on the same mesh (got degrees " + std::to_string(k) + " and " +
                     std::to_string(pressure.degree()) + ")");
  const auto& lower = multi_indices(pressure.degree());
  raise_.resize(lower.size() * 4);
  for (size_t c = 0; c < lower.size(); ++c)
    for (int i = 0; i < 4; ++i) {
      MultiIndex a = lower[c];
      ++a[i];
      raise_[c * 4 + i] = local_index(a);
    }
  free_ = &u.assembler().free_index();  // the assembler (built on first use) numbers the nodes
  held_ = &u.constrained_free_dofs();
  const index_t ne = u.space().mesh().num_tets();
  const int nu = u.space().nodes_per_element();
  dofs_.resize(static_cast<size_t>(ne) * nu);
  has_held_.assign(static_cast<size_t>(ne), 0);
  for (index_t e = 0; e < ne; ++e) {
    const index_t* un = u.space().element_nodes(e);
    for (int a = 0; a < nu; ++a) {
      const index_t f = (*free_)[un[a]];
      dofs_[static_cast<size_t>(e) * nu + a] = f < 0 ? -1 : 3 * f;
      if (f >= 0 && !held_->empty())
        for (int c = 0; c < 3; ++c)
          if ((*held_)[3 * f + c]) has_held_[static_cast<size_t>(e)] = 1;
    }
  }
  const Eigen::MatrixXd& M = element_tables(pressure.degree()).mass;
  mass_.resize(M.size());
  for (int b = 0; b < M.rows(); ++b)
    for (int c = 0; c < M.cols(); ++c) mass_[b * M.cols() + c] = M(b, c);
}

void DivergenceCoupling::gradients(index_t e, double gr[4][3]) const {
  const ElementGeometry& g = u_.geometry(e);
  if (!R_) {
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) gr[i][j] = g.grad(i, j);
    return;
  }
  const Mat3& R = (*R_)[static_cast<size_t>(e)];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) gr[i][j] = R(j, 0) * g.grad(i, 0) + R(j, 1) * g.grad(i, 1) + R(j, 2) * g.grad(i, 2);
}

template <int K>
void DivergenceCoupling::add_divergence(const double gr[4][3], const double (*w)[3], double v6, const index_t* pn,
                                        double* y_p) const {
  constexpr int NP = K * (K + 1) * (K + 2) / 6;
  const double* M = mass_.data();  // row-major NP x NP
  const int* raise = raise_.data();
  double d[NP];
  for (int c = 0; c < NP; ++c) {
    double sum = 0.0;
    for (int i = 0; i < 4; ++i) {
      const double* ww = w[raise[c * 4 + i]];
      sum += gr[i][0] * ww[0] + gr[i][1] * ww[1] + gr[i][2] * ww[2];
    }
    d[c] = K * sum;
  }
  for (int b = 0; b < NP; ++b) {
    double yb = 0.0;
    for (int c = 0; c < NP; ++c) yb += M[b * NP + c] * d[c];
    y_p[pn[b]] += v6 * yb;
  }
}

template <int K>
void DivergenceCoupling::element(index_t e, const double* x_u, const double* x_p, double* y_u, double* y_p) const {
  constexpr int NU = (K + 1) * (K + 2) * (K + 3) / 6, NP = K * (K + 1) * (K + 2) / 6;
  const double* M = mass_.data();  // row-major NP x NP
  const int* raise = raise_.data();
  const index_t* dof = dofs_.data() + static_cast<size_t>(e) * NU;
  const char* held = has_held_[static_cast<size_t>(e)] ? held_->data() : nullptr;
  const double v6 = 6.0 * u_.geometry(e).volume;
  double gr[4][3];
  gradients(e, gr);
  const index_t* pn = pressure_.element_nodes(e);
  if (x_u) {  // y_p += B_e x_u
    double ul[NU][3];
    for (int a = 0; a < NU; ++a) {
      const index_t d = dof[a];
      for (int c = 0; c < 3; ++c) ul[a][c] = d < 0 || (held && held[d + c]) ? 0.0 : x_u[d + c];
    }
    add_divergence<K>(gr, ul, v6, pn, y_p);
  }
  if (!x_p) return;
  // y_u += Bᵀ_e x_p: s = 6V M̂ p, then u_{c+e_i} += k s_c ∇λ_i.
  double pl[NP], s[NP], ua[NU][3] = {};
  for (int c = 0; c < NP; ++c) pl[c] = x_p[pn[c]];
  for (int b = 0; b < NP; ++b) {
    double sb = 0.0;
    for (int c = 0; c < NP; ++c) sb += M[b * NP + c] * pl[c];
    s[b] = K * v6 * sb;
  }
  for (int c = 0; c < NP; ++c)
    for (int i = 0; i < 4; ++i) {
      double* uu = ua[raise[c * 4 + i]];
      for (int j = 0; j < 3; ++j) uu[j] += s[c] * gr[i][j];
    }
  for (int a = 0; a < NU; ++a) {
    const index_t d = dof[a];
    if (d < 0) continue;
    for (int c = 0; c < 3; ++c)
      if (!held || !held[d + c]) y_u[d + c] += ua[a][c];
  }
}

template <class Element>
void DivergenceCoupling::over_elements(double* y_u, double* y_p, const Element& element) const {
  // Each thread runs a contiguous range of elements (their nodes close in memory) into its own
  // accumulators, summed afterwards: no colours, so no barrier per colour.
  const index_t np = rows(), nu = cols();
  const long ne = u_.space().mesh().num_tets();
  const int threads = omp_get_max_threads();
  const std::lock_guard<std::mutex> lock(buffers_mutex_);  // one product at a time uses the buffers
  const size_t others = static_cast<size_t>(std::max(threads - 1, 0));
  if (y_p && bufp_.size() != others * np) bufp_.assign(others * np, 0.0);
  if (y_u && bufu_.size() != others * nu) bufu_.assign(others * nu, 0.0);
#pragma omp parallel num_threads(threads)
  {
    const int tid = omp_get_thread_num(), nt = omp_get_num_threads();
    double* yp = nullptr;
    double* yu = nullptr;
    if (y_p) {
      yp = tid == 0 ? y_p : bufp_.data() + static_cast<size_t>(tid - 1) * np;
      std::fill(yp, yp + np, 0.0);
    }
    if (y_u) {
      yu = tid == 0 ? y_u : bufu_.data() + static_cast<size_t>(tid - 1) * nu;
      if (tid > 0) std::fill(yu, yu + nu, 0.0);
    }
    const long begin = ne * tid / nt, end = ne * (tid + 1) / nt;
    for (long e = begin; e < end; ++e) element(static_cast<index_t>(e), yu, yp);
    if (nt > 1) {
#pragma omp barrier
      if (y_p) {
#pragma omp for schedule(static)
        for (index_t i = 0; i < np; ++i)
          for (int k = 0; k + 1 < nt; ++k) y_p[i] += bufp_[static_cast<size_t>(k) * np + i];
      }
      if (y_u) {
#pragma omp for schedule(static)
        for (index_t i = 0; i < nu; ++i)
          for (int k = 0; k + 1 < nt; ++k) y_u[i] += bufu_[static_cast<size_t>(k) * nu + i];
      }
    }
  }
}

void DivergenceCoupling::apply(const double* x_u, const double* x_p, double* y_u, double* y_p) const {
  const bool cubic = u_.space().degree() == 3;
  over_elements(x_p ? y_u : nullptr, x_u ? y_p : nullptr, [&](index_t e, double* yu, double* yp) {
    if (cubic) element<3>(e, x_u, x_p, yu, yp);
    else element<2>(e, x_u, x_p, yu, yp);
  });
}

template <int K>
void DivergenceCoupling::element_state(index_t e, const double* u_full, const Rotations* R, double* g) const {
  constexpr int NU = (K + 1) * (K + 2) * (K + 3) / 6;
  const ElementGeometry& geo = u_.geometry(e);
  const index_t* un = u_.space().element_nodes(e);
  // w_a = R_eᵀ x_a - X_a (u_a without rotations), tested with the unrotated gradients.
  double w[NU][3], gr[4][3];
  const Mat3* Re = R ? &(*R)[static_cast<size_t>(e)] : nullptr;
  for (int a = 0; a < NU; ++a) {
    Vec3 wa(u_full[3 * un[a]], u_full[3 * un[a] + 1], u_full[3 * un[a] + 2]);
    if (Re) {
      const Vec3& X = u_.space().positions()[static_cast<size_t>(un[a])];
      wa = Re->transpose() * (X + wa) - X;
    }
    for (int c = 0; c < 3; ++c) w[a][c] = wa[c];
  }
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) gr[i][j] = geo.grad(i, j);
  add_divergence<K>(gr, w, 6.0 * geo.volume, pressure_.element_nodes(e), g);
}

void DivergenceCoupling::state_divergence(const Vector& u_full, const Rotations* R, Vector& g) const {
  if (u_full.size() != u_.num_dofs())
    throw InputError("state divergence: the displacement has " + std::to_string(u_full.size()) + " entries for " +
                     std::to_string(u_.num_dofs()));
  if (R && R->size() != static_cast<size_t>(u_.space().mesh().num_tets()))
    throw InputError("state divergence: " + std::to_string(R->size()) + " rotations for " +
                     std::to_string(u_.space().mesh().num_tets()) + " elements");
  g.resize(pressure_.num_nodes());
  const bool cubic = u_.space().degree() == 3;
  over_elements(nullptr, g.data(), [&](index_t e, double*, double* yp) {
    if (cubic) element_state<3>(e, u_full.data(), R, yp);
    else element_state<2>(e, u_full.data(), R, yp);
  });
}

void MixedElasticity::assemble_divergence() const {
  const ElasticityModel& u = hierarchy_->finest();
  const MixedTables& t = mixed_tables(u.space().degree());
  const std::vector<index_t>& free = u.assembler().free_index();
  const std::vector<char>& held = u.constrained_free_dofs();
  std::vector<Triplet> b;
  b.reserve(static_cast<size_t>(u.space().mesh().num_tets()) * t.np * 3 * t.nu);
  Eigen::MatrixXd Be;
  for (index_t e = 0; e < u.space().mesh().num_tets(); ++e) {
    element_divergence(t, u.geometry(e), Be);
    for (int q = 0; q < t.np; ++q) {
      const index_t row = pressure_.node(e, q);
      for (int a = 0; a < t.nu; ++a) {
        const index_t f = free[u.space().node(e, a)];
        if (f < 0) continue;
        for (int c = 0; c < 3; ++c) {
          const index_t col = 3 * f + c;
          if (!held.empty() && held[col]) continue;
          b.emplace_back(row, col, Be(q, 3 * a + c));
        }
      }
    }
  }
  B_ = Csr::from_triplets(num_pressure(), num_displacement(), b);
  Bt_ = B_.transposed();
}

const Csr& MixedElasticity::divergence() const {
  std::call_once(divergence_once_, [this] { assemble_divergence(); });
  return B_;
}

const Csr& MixedElasticity::divergence_transpose() const {
  std::call_once(divergence_once_, [this] { assemble_divergence(); });
  return Bt_;
}

void MixedElasticity::assemble_pressure_mass() {
  const ElasticityModel& u = hierarchy_->finest();
  const int np = pressure_.nodes_per_element();
  const Eigen::MatrixXd& mass = element_tables(pressure_.degree()).mass;
  std::vector<Triplet> mp;
  mp.reserve(static_cast<size_t>(u.space().mesh().num_tets()) * np * np);
  for (index_t e = 0; e < u.space().mesh().num_tets(); ++e)
    for (int q = 0; q < np; ++q)
      for (int q2 = 0; q2 < np; ++q2)
        mp.emplace_back(pressure_.node(e, q), pressure_.node(e, q2), 6.0 * u.geometry(e).volume * mass(q, q2));
  Mp_ = Csr::from_triplets(num_pressure(), num_pressure(), mp);
  C_ = Mp_;
  const MixedTables& t = mixed_tables(u.space().degree());
  coupling_ = std::make_unique<DivergenceCoupling>(u, pressure_);
  blocks_.coupling = coupling_.get();
  blocks_.C = compressibility();
  blocks_.pressure_mass = &Mp_;
  blocks_.mass_lo = t.mass_lo;
  blocks_.mass_hi = t.mass_hi;
  set_weights(weights_);
}

void MixedElasticity::set_weights(SystemWeights w) {
  if (!(w.stiffness > 0 && std::isfinite(w.stiffness)) || !(w.mass >= 0 && std::isfinite(w.mass)))
    throw InputError("mixed elements: the weights need a stiffness weight > 0 and a mass weight >= 0");
  weights_ = w;
  const std::vector<double>& mp = Mp_.values();
  std::vector<double>& c = C_.values();
  for (size_t i = 0; i < c.size(); ++i) c[i] = mp[i] * lambda_inverse_ / w.stiffness;
  blocks_.schur_scale = (1.0 / material_.mu() + lambda_inverse_) / w.stiffness;
}

Vector MixedElasticity::rhs(const Vector& f_full) const {
  const ElasticityModel& u = hierarchy_->finest();
  Vector fu = u.restrict_to_free(f_full);
  u.constrain(fu);
  Vector b = Vector::Zero(num_unknowns());
  b.head(num_displacement()) = fu;
  return b;
}

Csr MixedElasticity::assembled_system() {
  const int top = hierarchy_->num_levels() - 1;
  hierarchy_->assemble_level(top, nullptr, nullptr, weights_.mass, weights_.stiffness);
  const Csr A = hierarchy_->matrix(top).to_csr();
  const index_t nu = num_displacement();
  std::vector<Triplet> t;
  t.reserve(static_cast<size_t>(A.nnz() + 2 * divergence().nnz() + C_.nnz()));
  auto add = [&t](const Csr& M, index_t r0, index_t c0, double s) {
    const CsrPattern& p = M.pattern();
    for (index_t i = 0; i < M.rows(); ++i)
      for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) t.emplace_back(r0 + i, c0 + p.col_idx[k], s * M.values()[k]);
  };
  add(A, 0, 0, 1.0);
  add(divergence_transpose(), 0, nu, 1.0);
  add(divergence(), nu, 0, 1.0);
  if (lambda_inverse_ > 0) add(C_, nu, nu, -1.0);
  else
    for (index_t i = 0; i < num_pressure(); ++i) t.emplace_back(nu + i, nu + i, 0.0);  // keep the diagonal
  return Csr::from_triplets(num_unknowns(), num_unknowns(), t);
}

Vector MixedElasticity::pressure_on_displacement_nodes(const Vector& p) const {
  if (p.size() != num_pressure())
    throw InputError("pressure: " + std::to_string(p.size()) + " values for " + std::to_string(num_pressure()) +
                     " pressure nodes");
  const BBSpace& fine = hierarchy_->finest().space();
  std::call_once(elevation_once_, [&] {  // built once: every frame of a run raises its pressure
    std::vector<index_t> all_fine(fine.num_nodes()), all_coarse(pressure_.num_nodes());
    for (index_t i = 0; i < fine.num_nodes(); ++i) all_fine[i] = i;
    for (index_t i = 0; i < pressure_.num_nodes(); ++i) all_coarse[i] = i;
    elevation_ = degree_elevation(fine, all_fine, pressure_, all_coarse);
  });
  Vector out(fine.num_nodes());
  elevation_.multiply(p.data(), out.data());
  return out;
}

double MixedElasticity::pressure_at(const Vector& p, index_t e, const Eigen::Vector4d& l) const {
  const auto& alpha = multi_indices(pressure_.degree());
  double v = 0.0;
  for (int b = 0; b < pressure_.nodes_per_element(); ++b) v += p[pressure_.node(e, b)] * bernstein(alpha[b], l);
  return v;
}

Vector MixedElasticity::state_divergence(const Vector& u_full, const Rotations* R) const {
  Vector g;
  coupling_->state_divergence(u_full, R, g);
  return g;
}

Vector MixedElasticity::pressure_of(const Vector& u_full, const Rotations* R) const {
  return pressure_from_divergence(state_divergence(u_full, R));
}

Vector MixedElasticity::pressure_from_divergence(const Vector& g) const {
  if (lambda_inverse_ == 0)
    throw InputError("mixed elements: at nu = 0.5 the pressure is not a function of the displacement (a "
                     "deformed initial state has no finite energy); start at rest, or give the pressure");
  if (g.size() != num_pressure())
    throw InputError("mixed elements: a divergence of " + std::to_string(g.size()) + " values for " +
                     std::to_string(num_pressure()) + " pressure nodes");
  const Vector b = g / lambda_inverse_;
  const MixedTables& t = mixed_tables(hierarchy_->finest().space().degree());
  const ChebyshevMassInverse M(Mp_, t.mass_lo, t.mass_hi, 8);
  KrylovParams kp;
  kp.rel_tol = 1e-12;
  kp.max_iterations = 1000;
  Vector p = Vector::Zero(num_pressure());
  const SolveResult r = pcg(Mp_, &M, b, p, kp);
  if (!r.ok()) throw Error("mixed elements: the pressure of the state: " + r.message);
  return p;
}

namespace {
/// The one refusal of a direct method for corotational material (before it factorises anything).
void refuse_direct_with_rotations(const std::string& method) {
  throw InputError("mixed elements: " + method +
                   " is set up once on the assembled linear saddle point; corotational material needs mixed-gmres or "
                   "mixed-minres");
}
}  // namespace

MixedSolver::MixedSolver(MixedElasticity& m, const Config& config, bool corotational) : m_(m) {
  const std::string method = config.get_string("method", "mixed-gmres");
  if (corotational && !method_uses_levels(method)) refuse_direct_with_rotations(method);
  m_.set_rotations(nullptr);  // linear until rotate() says otherwise
  SolverContext ctx;
  ctx.levels = &m.hierarchy();
  ctx.saddle_point = &m.blocks();
  std::vector<double> coordinates;  // the displacement nodes', for an assembled method (GAMG's rigid modes)
  if (!method_uses_levels(method)) {
    const Vector xyz = m.hierarchy().finest().free_positions();
    coordinates.assign(xyz.data(), xyz.data() + xyz.size());
    ctx.coordinates = &coordinates;
  }
  solver_ = make_solver(config, ctx, "mixed-gmres");
  bound_ = std::make_unique<BoundSystem>(m.hierarchy().bind(*solver_));
  const auto t0 = Clock::now();
  // A method on the levels (mixed-gmres, mixed-minres) multiplies with the operator; any other
  // (MUMPS, PETSc's fieldsplit) reads the assembled saddle point.
  if (method_uses_levels(method)) {
    const LinearOperator& A = bound_->prepare(nullptr, m.weights());
    K_ = std::make_unique<SaddlePointOperator>(A, m.coupling(), m.compressibility());
    solver_->setup(*K_);
  } else {
    assembled_ = m.assembled_system();
    solver_->setup(assembled_);
  }
  setup_seconds_ = seconds_since(t0);
}

MixedSolver::~MixedSolver() = default;

void MixedSolver::rotate(const Rotations* R, bool finest) {
  if (!K_) refuse_direct_with_rotations(solver_->name());
  m_.set_rotations(R);
  bound_->prepare(R, m_.weights(), finest);
  solver_->update();
}

SolveResult MixedSolver::solve(const Vector& b, Vector& x, SolveMonitor* monitor) {
  return solver_->solve(b, x, monitor);
}

double MixedSolver::residual_norm(const Vector& b, const Vector& x) const {
  Vector r(b.size());
  if (K_) K_->apply(x, r);
  else assembled_.multiply(x.data(), r.data());
  return (b - r).norm();
}

std::string MixedSolver::description() const {
  return solver_->name() + (solver_->describe().empty() ? "" : ": " + solver_->describe());
}

namespace {

/// The corotational fixed point of solve_mixed_static() on z = (u full, p): each correction solves
/// the system at the rotations of u (see mixed.hpp); the norm is the displacement's.
class MixedStaticPart final : public StaticPart {
 public:
  MixedStaticPart(MixedElasticity& m, MixedSolver& solver, const Vector& f, SolveMonitor* monitor, MixedResult& out)
      : m_(m), solver_(solver), f_(f), monitor_(monitor), out_(out) {}
  Vector correction(const Vector& z, int iteration) override {
    const ElasticityModel& model = m_.hierarchy().finest();
    const index_t n = model.num_dofs(), nu = m_.num_displacement(), np = m_.num_pressure();
    const Vector u = z.head(n), p = z.tail(np);
    R_ = model.rotations(u);
    Vector force(n);
    solver_.bound().evaluate(u, &R_, m_.weights(), &force, nullptr);
    solver_.rotate(&R_, false);
    Vector b(nu + np), btp = Vector::Zero(nu);
    m_.coupling().apply(nullptr, p.data(), btp.data(), nullptr);  // B_Rᵀ p
    b.head(nu) = model.restrict_to_free(f_ + force) - btp;
    b.tail(np) = -m_.state_divergence(u, &R_);
    if (const Csr* C = m_.compressibility()) {
      Vector cp(np);
      C->multiply(p.data(), cp.data());
      b.tail(np) += cp;
    }
    Vector x = Vector::Zero(nu + np);
    try {
      out_.solve = solver_.solve(b, x, monitor_);
    } catch (const SolveError& e) {
      SolveResult r = e.result;
      r.message = "mixed static solve: fixed-point iteration " + std::to_string(iteration) + ": " + e.what();
      throw SolveError(r);
    }
    out_.solver_iterations += out_.solve.iterations;
    if (!out_.solve.ok()) {  // a solver that does not throw on failure (throw_on_failure=false)
      SolveResult r = out_.solve;
      r.message = "mixed static solve: fixed-point iteration " + std::to_string(iteration) + ": " +
                  (r.message.empty() ? std::string("the solver ended with ") + to_string(r.status) : r.message);
      throw SolveError(r);
    }
    Vector step(n + np);
    step << model.expand(x.head(nu), Vector::Zero(n)), x.tail(np);
    return step;
  }
  double norm(const Vector& z) const override { return z.head(m_.hierarchy().finest().num_dofs()).norm(); }

 private:
  MixedElasticity& m_;
  MixedSolver& solver_;
  const Vector& f_;
  SolveMonitor* monitor_;
  MixedResult& out_;
  Rotations R_;  // the last correction's, read by the coupling until the next
};

}  // namespace

MixedResult solve_mixed_static(MixedElasticity& m, const Vector& f_full, const Config& config, SolveMonitor* monitor,
                               bool corotational, const StaticOptions& fixed_point) {
  const ElasticityModel& model = m.hierarchy().finest();
  if (f_full.size() != model.num_dofs())
    throw InputError("mixed solve: force vector has " + std::to_string(f_full.size()) + " entries, model has " +
                     std::to_string(model.num_dofs()) + " dofs");
  if (!f_full.allFinite()) throw InputError("mixed solve: force vector has NaN/Inf");
  if (m.num_displacement() == 0)
    throw InputError("mixed solve: every displacement node is fixed: nothing to solve; fix part of the boundary");
  if (model.num_fixed() == 0 && m.weights().mass == 0.0)
    throw InputError("mixed solve: no node is fixed, so the static displacement block is singular (rigid motions); "
                     "fix part of the boundary");
  if (corotational && (m.weights().mass != 0.0 || m.weights().stiffness != 1.0))
    throw InputError("mixed solve: the corotational fixed point is a static solve (set_weights({0, 1}))");
  MixedResult out;
  MixedSolver solver(m, config, corotational);
  out.description = solver.description();
  if (corotational) {
    const auto t1 = Clock::now();
    MixedStaticPart part(m, solver, f_full, monitor, out);
    Vector z = Vector::Zero(model.num_dofs() + m.num_pressure());
    try {
      out.fixed_point_iterations = corotational_fixed_point(part, z, true, fixed_point, "mixed static solve").iterations;
    } catch (...) {
      m.set_rotations(nullptr);  // the part's rotations die with it
      throw;
    }
    m.set_rotations(nullptr);
    out.setup_seconds = solver.setup_seconds();
    out.solve_seconds = seconds_since(t1);
    out.u = z.head(model.num_dofs());
    out.p = z.tail(m.num_pressure());
    return out;
  }
  const Vector b = m.rhs(f_full);
  out.setup_seconds = solver.setup_seconds();
  Vector x = Vector::Zero(m.num_unknowns());
  const auto t1 = Clock::now();
  out.solve = solver.solve(b, x, monitor);
  out.solver_iterations = out.solve.iterations;
  out.solve_seconds = seconds_since(t1);
  out.u = model.expand(x.head(m.num_displacement()), Vector::Zero(model.num_dofs()));
  out.p = x.tail(m.num_pressure()) / m.weights().stiffness;
  return out;
}

}  // namespace pmg::fem
