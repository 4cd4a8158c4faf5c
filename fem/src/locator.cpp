#include "pmg/fem/locator.hpp"

#include <algorithm>
#include <cmath>

namespace pmg::fem {

PointLocator::PointLocator(const ElasticityModel& model) : model_(model) {
  const TetMesh& mesh = model.space().mesh();
  lo_ = Vec3::Constant(1e300);
  Vec3 hi = Vec3::Constant(-1e300);
  for (const Vec3& X : mesh.vertices) lo_ = lo_.cwiseMin(X), hi = hi.cwiseMax(X);
  const Vec3 ext = (hi - lo_).cwiseMax(1e-300);
  // About one element per cell, cells as cubic as the box allows.
  const double cell_size = std::cbrt(ext.prod() / std::max<index_t>(1, mesh.num_tets()));
  for (int d = 0; d < 3; ++d) {
    n_[d] = std::clamp(static_cast<int>(ext[d] / std::max(cell_size, 1e-300 * ext.maxCoeff())), 1, 512);
    h_[d] = ext[d] / n_[d];
  }
  const index_t cells = static_cast<index_t>(n_[0]) * n_[1] * n_[2];
  std::vector<std::array<int, 6>> range(mesh.num_tets());
  start_.assign(cells + 1, 0);
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    Vec3 a = Vec3::Constant(1e300), b = Vec3::Constant(-1e300);
    for (index_t v : mesh.tets[e]) a = a.cwiseMin(mesh.vertices[v]), b = b.cwiseMax(mesh.vertices[v]);
    auto& r = range[e];
    for (int d = 0; d < 3; ++d) r[d] = coord(a, d), r[3 + d] = coord(b, d);
    for (int k = r[2]; k <= r[5]; ++k)
      for (int j = r[1]; j <= r[4]; ++j)
        for (int i = r[0]; i <= r[3]; ++i) ++start_[cell(i, j, k) + 1];
  }
  for (index_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
  elements_.resize(start_[cells]);
  std::vector<index_t> fill(start_.begin(), start_.end() - 1);
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    const auto& r = range[e];
    for (int k = r[2]; k <= r[5]; ++k)
      for (int j = r[1]; j <= r[4]; ++j)
        for (int i = r[0]; i <= r[3]; ++i) elements_[fill[cell(i, j, k)]++] = e;
  }
}

int PointLocator::coord(const Vec3& X, int d) const {
  const double t = std::floor((X[d] - lo_[d]) / h_[d]);
  return static_cast<int>(std::clamp(t, 0.0, static_cast<double>(n_[d] - 1)));
}

std::pair<index_t, Eigen::Vector4d> PointLocator::locate(const Vec3& X) const {
  const double tol = 1e-10;
  const TetMesh& mesh = model_.space().mesh();
  index_t best = -1;
  double best_min = -1e300;
  Eigen::Vector4d best_l = Eigen::Vector4d::Zero();
  if (X.allFinite()) {
    const index_t c = cell(coord(X, 0), coord(X, 1), coord(X, 2));
    for (index_t q = start_[c]; q < start_[c + 1]; ++q) {
      const index_t e = elements_[q];
      const Eigen::Vector4d l = barycentric(model_.geometry(e), mesh.vertices[mesh.tets[e][0]], X);
      if (l.minCoeff() > best_min) best_min = l.minCoeff(), best = e, best_l = l;
    }
  }
  if (best < 0 || best_min < -tol)
    throw InputError("point (" + std::to_string(X.x()) + ", " + std::to_string(X.y()) + ", " +
                     std::to_string(X.z()) + ") lies outside the mesh");
  return {best, best_l};
}

void PointLocator::displacements(const Vector& u, const double* points, index_t count, double* out) const {
  if (u.size() != model_.num_dofs())
    throw InputError("displacement has " + std::to_string(u.size()) + " entries, the model " +
                     std::to_string(model_.num_dofs()) + " dofs (3 per node, the full vector)");
  for (index_t p = 0; p < count; ++p) {
    const Vec3 X(points[3 * p], points[3 * p + 1], points[3 * p + 2]);
    const auto [e, l] = locate(X);
    const Vec3 d = model_.displacement_at(u, e, l);
    out[3 * p] = d.x(), out[3 * p + 1] = d.y(), out[3 * p + 2] = d.z();
  }
}

}  // namespace pmg::fem
