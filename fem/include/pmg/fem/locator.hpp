// pmg/fem/locator.hpp — which element holds a point: a uniform grid over the mesh's bounding box
// with each element listed in the cells its bounding box overlaps (about one element per cell),
// so a query tests a handful of elements instead of all of them (ElasticityModel::locate's scan).
#pragma once

#include "pmg/fem/elasticity.hpp"

#include <utility>
#include <vector>

namespace pmg::fem {

/// A uniform-grid index of an ElasticityModel's elements for fast point location (see the file
/// comment).
class PointLocator {
 public:
  /// Keeps a reference to the model (and its mesh), which must outlive the locator.
  explicit PointLocator(const ElasticityModel& model);
  /// Element containing rest point X and its barycentric coordinates, as ElasticityModel::locate
  /// (the element whose smallest barycentric coordinate is largest); throws InputError if X is
  /// outside the mesh.
  std::pair<index_t, Eigen::Vector4d> locate(const Vec3& X) const;
  /// Displacements (x, y, z per point) of u at `count` points given as x, y, z triples.
  void displacements(const Vector& u, const double* points, index_t count, double* out) const;

 private:
  index_t cell(int i, int j, int k) const { return (static_cast<index_t>(k) * n_[1] + j) * n_[0] + i; }
  int coord(const Vec3& X, int d) const;

  const ElasticityModel& model_;
  Vec3 lo_, h_;
  int n_[3] = {1, 1, 1};
  std::vector<index_t> start_, elements_;  ///< elements of cell c: elements_[start_[c] .. start_[c+1])
};

}  // namespace pmg::fem
