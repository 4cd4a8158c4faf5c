// The manufactured solution of mixed elasticity (mixed_manufactured.hpp) solved on Kuhn cubes by
// the mixed and the displacement-only elements, with L2 errors of displacement and pressure: shared
// by tests/multigrid/test_mixed.cpp and bench/fem/mixed_accuracy.cpp.
#pragma once

#include "mixed_manufactured.hpp"
#include "pmg/fem/mixed.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/sparse/config.hpp"

#include <cmath>
#include <sstream>

namespace pmg::fem::test {

inline Material mms_material(double nu) { return Material{1.0, nu, 1.0}; }

inline std::vector<char> clamp_cube_boundary(const TetMesh& m) {
  std::vector<char> c(m.vertices.size());
  for (size_t v = 0; v < m.vertices.size(); ++v)
    for (int d = 0; d < 3; ++d) c[v] |= m.vertices[v][d] < 1e-12 || m.vertices[v][d] > 1 - 1e-12;
  return c;
}

inline Config mixed_config(const std::string& method, double tol) {
  std::ostringstream t;
  t << "tol=" << tol;
  return Config::from_pairs({"method=" + method, t.str()}, "test");
}

inline Config mixed_minres_config(double tol) { return mixed_config("mixed-minres", tol); }

/// The unit cube in nx x ny x nz cells of 6 Kuhn (Freudenthal) tetrahedra each, all sharing the cell's diagonal: a
/// mesh without the 24-tet cells' rich divergence-free subspace, on which displacement-only
/// elements lock.
inline TetMesh kuhn_grid(int nx, int ny, int nz) {
  TetMesh m;
  auto id = [nx, ny](int i, int j, int k) { return static_cast<index_t>((k * (ny + 1) + j) * (nx + 1) + i); };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) m.vertices.emplace_back(double(i) / nx, double(j) / ny, double(k) / nz);
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        for (const auto& p : perms) {
          int c[3] = {i, j, k};
          Tet t;
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          m.tets.push_back(t);
          if (m.signed_volume(m.num_tets() - 1) < 0) std::swap(m.tets.back()[1], m.tets.back()[2]);
        }
  return m;
}

/// The unit cube in n³ Kuhn cells.
inline TetMesh kuhn_cube(int n) { return kuhn_grid(n, n, n); }

struct MmsErrors {
  double u = 0, p = 0;
};

/// L2 errors of displacement and pressure against the manufactured solution (quadrature exact to
/// degree 2k + 4); without a mixed model the pressure is λ div u_h of the displacement-only elements.
inline MmsErrors mms_errors(const ElasticityModel& model, const Vector& u, const MixedElasticity* mixed, const Vector& p,
                     double lambda_inverse) {
  const BBSpace& s = model.space();
  const TetMesh& mesh = s.mesh();
  const QuadratureRule& q = tet_quadrature(2 * s.degree() + 4);
  MmsErrors err;
  for (index_t e = 0; e < mesh.num_tets(); ++e)
    for (size_t k = 0; k < q.points.size(); ++k) {
      const Eigen::Vector4d& l = q.points[k];
      Vec3 x = Vec3::Zero();
      for (int i = 0; i < 4; ++i) x += l[i] * mesh.vertices[mesh.tets[e][i]];
      const double w = q.weights[k] * model.geometry(e).volume;
      const Vec3 exact = mixed_mms::u_df(x) + lambda_inverse * mixed_mms::grad_phi(x);
      err.u += w * (model.displacement_at(u, e, l) - exact).squaredNorm();
      double ph = 0.0;
      if (mixed) ph = mixed->pressure_at(p, e, l);
      else
        for (int a = 0; a < s.nodes_per_element(); ++a)
          ph += u.segment<3>(3 * s.node(e, a)).dot(model.geometry(e).grad.transpose() *
                                                    bernstein_gradient(multi_indices(s.degree())[a], l)) /
                lambda_inverse;
      err.p += w * std::pow(ph - mixed_mms::pressure(x), 2);
    }
  return {std::sqrt(err.u), std::sqrt(err.p)};
}

inline std::function<Vec3(const Vec3&)> mms_force(const Material& m) {
  const double mu = m.mu(), li = m.poisson == 0.5 ? 0.0 : 1.0 / m.lambda();
  return [mu, li](const Vec3& x) {
    return Vec3(-mu * mixed_mms::lap_u_df(x) - (1 + 2 * mu * li) * mixed_mms::grad_lap_phi(x));
  };
}

inline MmsErrors mms_mixed(int n, int k, double nu) {
  const TetMesh mesh = kuhn_cube(n);
  MixedElasticity m(mesh, k, mms_material(nu), clamp_cube_boundary(mesh));
  const Vector f = m.hierarchy().finest().body_force(mms_force(m.material()), 2 * k + 2);
  const MixedResult r = solve_mixed_static(m, f, mixed_minres_config(1e-11));
  return mms_errors(m.hierarchy().finest(), r.u, &m, r.p, nu == 0.5 ? 0.0 : 1.0 / m.material().lambda());
}

inline MmsErrors mms_displacement(int n, int k, double nu) {
  const TetMesh mesh = kuhn_cube(n);
  ElasticityModel model(mesh, k, mms_material(nu));
  model.fix_vertices(clamp_cube_boundary(mesh));
  const Vector f = model.body_force(mms_force(model.material()), 2 * k + 2);
  const Vector u = solve_static(model, f, false).u;
  return mms_errors(model, u, nullptr, Vector(), 1.0 / model.material().lambda());
}

}  // namespace pmg::fem::test
