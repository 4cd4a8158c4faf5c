// Manufactured displacement fields with exact gradients and Hessians, the body force that makes
// them equilibrium solutions, and error norms of a BB displacement against them.
#pragma once

#include "pmg/fem/elasticity.hpp"

#include <cmath>
#include <functional>
#include <random>

namespace pmg::fem::test {

struct Field {
  std::function<Vec3(const Vec3&)> value;
  std::function<Mat3(const Vec3&)> gradient;                  ///< G(i,j) = ∂_j u_i
  std::function<std::array<Mat3, 3>(const Vec3&)> hessian;    ///< H[i](j,k) = ∂_j ∂_k u_i
};

/// b = -div σ(u) for isotropic linear elasticity: b_i = -(μ Δu_i + (λ+μ) ∂_i div u).
inline std::function<Vec3(const Vec3&)> body_force_for(const Field& u, const Material& m) {
  const double lam = m.lambda(), mu = m.mu();
  return [u, lam, mu](const Vec3& x) {
    const auto H = u.hessian(x);
    Vec3 b;
    for (int i = 0; i < 3; ++i) {
      double grad_div = 0.0;
      for (int j = 0; j < 3; ++j) grad_div += H[j](j, i);
      b[i] = -(mu * H[i].trace() + (lam + mu) * grad_div);
    }
    return b;
  };
}

/// A random polynomial field of total degree p (all monomials x^a y^b z^c, a+b+c <= p).
inline Field polynomial_field(int p, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  struct Term {
    int e[3];
    Vec3 c;
  };
  std::vector<Term> terms;
  for (int a = 0; a <= p; ++a)
    for (int b = 0; a + b <= p; ++b)
      for (int c = 0; a + b + c <= p; ++c) terms.push_back({{a, b, c}, Vec3(u(gen), u(gen), u(gen)) * 1e-3});
  // d^k/dx^k of x^e at x: e!/(e-k)! x^(e-k)
  auto dpow = [](double x, int e, int k) {
    if (k > e) return 0.0;
    double f = 1.0;
    for (int i = 0; i < k; ++i) f *= e - i;
    return f * std::pow(x, e - k);
  };
  auto eval = [terms, dpow](const Vec3& x, int dx, int dy, int dz) {
    Vec3 v = Vec3::Zero();
    for (const auto& t : terms)
      v += t.c * dpow(x[0], t.e[0], dx) * dpow(x[1], t.e[1], dy) * dpow(x[2], t.e[2], dz);
    return v;
  };
  Field f;
  f.value = [eval](const Vec3& x) { return eval(x, 0, 0, 0); };
  f.gradient = [eval](const Vec3& x) {
    Mat3 G;
    G.col(0) = eval(x, 1, 0, 0);
    G.col(1) = eval(x, 0, 1, 0);
    G.col(2) = eval(x, 0, 0, 1);
    return G;
  };
  f.hessian = [eval](const Vec3& x) {
    std::array<Mat3, 3> H;
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        int d[3] = {0, 0, 0};
        ++d[j];
        ++d[k];
        const Vec3 v = eval(x, d[0], d[1], d[2]);
        for (int i = 0; i < 3; ++i) H[i](j, k) = v[i];
      }
    return H;
  };
  return f;
}

/// u_i = a_i sin(ω_i · x + φ_i): smooth, not in any polynomial space.
inline Field sine_field() {
  const Vec3 amp(1e-2, -2e-2, 1.5e-2), phase(0.3, 1.1, -0.4);
  const Mat3 w = (Mat3() << 2.0, 1.0, 0.5, -1.0, 2.5, 1.0, 0.7, -0.6, 3.0).finished();  // row i = ω_i
  Field f;
  f.value = [=](const Vec3& x) {
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = amp[i] * std::sin(w.row(i).dot(x) + phase[i]);
    return v;
  };
  f.gradient = [=](const Vec3& x) {
    Mat3 G;
    for (int i = 0; i < 3; ++i) G.row(i) = amp[i] * std::cos(w.row(i).dot(x) + phase[i]) * w.row(i);
    return G;
  };
  f.hessian = [=](const Vec3& x) {
    std::array<Mat3, 3> H;
    for (int i = 0; i < 3; ++i)
      H[i] = -amp[i] * std::sin(w.row(i).dot(x) + phase[i]) * w.row(i).transpose() * w.row(i);
    return H;
  };
  return f;
}

struct Errors {
  double l2 = 0, energy = 0;
};

/// L2 error and energy-norm error sqrt(∫ (ε_h-ε):C:(ε_h-ε)) of the BB displacement u against f.
inline Errors errors(const ElasticityModel& model, const Vector& u, const Field& f) {
  const BBSpace& s = model.space();
  const TetMesh& mesh = s.mesh();
  const QuadratureRule& q = tet_quadrature(2 * s.degree() + 4);
  const auto& alpha = multi_indices(s.degree());
  const double lam = model.material().lambda(), mu = model.material().mu();
  Errors err;
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    const ElementGeometry& g = model.geometry(e);
    for (size_t k = 0; k < q.points.size(); ++k) {
      const Eigen::Vector4d& l = q.points[k];
      Vec3 x = Vec3::Zero();
      for (int i = 0; i < 4; ++i) x += l[i] * mesh.vertices[mesh.tets[e][i]];
      Vec3 uh = Vec3::Zero();
      Mat3 Gh = Mat3::Zero();
      for (int a = 0; a < s.nodes_per_element(); ++a) {
        const Vec3 b = u.segment<3>(3 * s.node(e, a));
        uh += bernstein(alpha[a], l) * b;
        const Vec3 gradB = g.grad.transpose() * bernstein_gradient(alpha[a], l);
        Gh += b * gradB.transpose();
      }
      const Mat3 dG = Gh - f.gradient(x);
      const Mat3 eps = 0.5 * (dG + dG.transpose());
      const double w = q.weights[k] * g.volume;
      err.l2 += w * (uh - f.value(x)).squaredNorm();
      err.energy += w * (2 * mu * eps.squaredNorm() + lam * eps.trace() * eps.trace());
    }
  }
  err.l2 = std::sqrt(err.l2);
  err.energy = std::sqrt(err.energy);
  return err;
}

}  // namespace pmg::fem::test
