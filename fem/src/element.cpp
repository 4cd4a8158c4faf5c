#include "pmg/fem/element.hpp"

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace pmg::fem {

namespace {

double factorial(int n) {
  double f = 1.0;
  for (int i = 2; i <= n; ++i) f *= i;
  return f;
}
double mfact(const MultiIndex& a) {
  return factorial(a[0]) * factorial(a[1]) * factorial(a[2]) * factorial(a[3]);
}
}  // namespace

double bernstein_product_integral(const MultiIndex& a, const MultiIndex& b) {
  const int p = a[0] + a[1] + a[2] + a[3], q = b[0] + b[1] + b[2] + b[3];
  MultiIndex s;
  for (int i = 0; i < 4; ++i) s[i] = a[i] + b[i];
  return factorial(p) / mfact(a) * factorial(q) / mfact(b) * mfact(s) / factorial(p + q + 3);
}

namespace {
ElementTables build_tables(int p) {
  ElementTables t;
  t.p = p;
  const auto& alpha = multi_indices(p);
  t.n = static_cast<int>(alpha.size());
  t.mass.resize(t.n, t.n);
  t.G.assign(static_cast<size_t>(t.n) * t.n, Eigen::Matrix4d::Zero());
  for (int a = 0; a < t.n; ++a)
    for (int b = 0; b < t.n; ++b) {
      t.mass(a, b) = bernstein_product_integral(alpha[a], alpha[b]);
      Eigen::Matrix4d& G = t.G[a * t.n + b];
      for (int k = 0; k < 4; ++k) {
        if (alpha[a][k] == 0) continue;
        MultiIndex ak = alpha[a];
        --ak[k];
        for (int l = 0; l < 4; ++l) {
          if (alpha[b][l] == 0) continue;
          MultiIndex bl = alpha[b];
          --bl[l];
          G(k, l) = p * p * bernstein_product_integral(ak, bl);
        }
      }
    }
  t.load = factorial(p) * factorial(3) / factorial(p + 3) / 6.0;
  return t;
}

// Grundmann & Möller (1978), "Invariant integration formulas for the n-simplex by combinatorial
// methods": degree 2s+1 exact with points (2β_i+1)/(d+2i) over compositions β of s-i.
QuadratureRule grundmann_moller(int s) {
  const int n = 3;  // dimension
  QuadratureRule r;
  std::map<std::array<long, 4>, size_t> index;  // merge coincident points
  for (int i = 0; i <= s; ++i) {
    const int d = 2 * s + n + 1 - 2 * i;  // denominator (d = n + 2(s-i) + 1)
    const double w = std::pow(-1.0, i) * std::pow(2.0, -2 * s) * std::pow(d, 2 * s + 1) /
                     (factorial(i) * factorial(d + i));
    const int m = s - i;
    // All β = (β0..β3) with Σ β = m.
    for (int b0 = 0; b0 <= m; ++b0)
      for (int b1 = 0; b0 + b1 <= m; ++b1)
        for (int b2 = 0; b0 + b1 + b2 <= m; ++b2) {
          const int b3 = m - b0 - b1 - b2;
          const int beta[4] = {b0, b1, b2, b3};
          Eigen::Vector4d lam;
          std::array<long, 4> key;
          for (int c = 0; c < 4; ++c) {
            lam[c] = (2.0 * beta[c] + 1.0) / d;
            key[c] = std::lround(lam[c] * 1e12);
          }
          // Weights are for the unit-volume-normalised simplex: multiply by n! · (1/n!) = 1.
          auto [it, inserted] = index.emplace(key, r.points.size());
          if (inserted) {
            r.points.push_back(lam);
            r.weights.push_back(w * factorial(n));
          } else {
            r.weights[it->second] += w * factorial(n);
          }
        }
  }
  return r;
}

}  // namespace

const ElementTables& element_tables(int p) {
  static const ElementTables tables[3] = {build_tables(1), build_tables(2), build_tables(3)};
  if (p < 1 || p > 3) throw InputError("degree " + std::to_string(p) + " not supported (1, 2 or 3)");
  return tables[p - 1];
}

const QuadratureRule& tet_quadrature(int exact_degree) {
  static std::mutex m;
  static std::map<int, std::unique_ptr<QuadratureRule>> cache;
  const int s = std::max(0, exact_degree / 2);  // 2s+1 >= exact_degree
  std::lock_guard<std::mutex> lock(m);
  auto& r = cache[s];
  if (!r) r = std::make_unique<QuadratureRule>(grundmann_moller(s));
  return *r;
}

ElementGeometry element_geometry(const Vec3& X0, const Vec3& X1, const Vec3& X2, const Vec3& X3) {
  Mat3 D;
  D.col(0) = X1 - X0;
  D.col(1) = X2 - X0;
  D.col(2) = X3 - X0;
  ElementGeometry g;
  g.volume = D.determinant() / 6.0;
  if (!(g.volume > 0.0))
    throw MeshError(g.volume < 0 ? "inverted element (negative volume)" : "degenerate element");
  const Mat3 Dinv = D.inverse();
  g.grad.row(1) = Dinv.row(0);
  g.grad.row(2) = Dinv.row(1);
  g.grad.row(3) = Dinv.row(2);
  g.grad.row(0) = -(Dinv.row(0) + Dinv.row(1) + Dinv.row(2));
  return g;
}

Eigen::Vector4d barycentric(const ElementGeometry& g, const Vec3& X0, const Vec3& x) {
  Eigen::Vector4d l;
  l.tail<3>() = g.grad.bottomRows<3>() * (x - X0);
  l[0] = 1.0 - l.tail<3>().sum();
  return l;
}

void element_stiffness(const ElementTables& t, const ElementGeometry& g, double lambda, double mu,
                       Eigen::MatrixXd& K) {
  const int n = t.n;
  K.resize(3 * n, 3 * n);
  const double scale = 6.0 * g.volume;
  for (int a = 0; a < n; ++a)
    for (int b = a; b < n; ++b) {
      Mat3 Kab;
      if (t.p == 1) {
        Kab = linear_element_block(g, lambda, mu, a, b);
      } else {
        Mat3 S = scale * (g.grad.transpose() * t.G[a * n + b] * g.grad);
        if (a == b) S = 0.5 * (S + S.transpose()).eval();  // symmetric to the last bit
        Kab = lambda * S + mu * S.transpose() + (mu * S.trace()) * Mat3::Identity();
      }
      K.block<3, 3>(3 * a, 3 * b) = Kab;
      if (b != a) K.block<3, 3>(3 * b, 3 * a) = Kab.transpose();
    }
}

}  // namespace pmg::fem
