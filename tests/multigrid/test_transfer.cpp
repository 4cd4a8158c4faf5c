#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/transfer.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace pmg;
using namespace pmg::fem;

namespace {
const TetMesh& bar() {
  static const TetMesh m = box_mesh_24(3, 1, 1, 1.0, 0.3, 0.3);
  return m;
}
bool clamped(const Vec3& X) { return X.x() < 1e-12; }
bool nothing(const Vec3&) { return false; }

std::vector<Mat3> random_rotations(index_t n, unsigned seed) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> g;
  std::vector<Mat3> R(n);
  for (auto& r : R) r = Eigen::Quaterniond(g(gen), g(gen), g(gen), g(gen)).normalized().toRotationMatrix();
  return R;
}
}  // namespace

TEST_CASE("degree elevation is exact: P maps a degree p-1 field to the same field of degree p",
          "[multigrid][transfer]") {
  const auto field = [](const Vec3& X) {
    return Vec3(X.x() * X.y() - X.z(), X.y() * X.y() + 0.5 * X.x(), 1.0 - X.z() * X.x());
  };
  DegreeHierarchy h(bar(), 3, Material{}, nothing);
  for (int l = 1; l < h.num_levels(); ++l) {
    const mg::BlockTransfer T(h.prolongation(l));
    const Vector coarse = h.model(l - 1).interpolate(field);  // exact for degree >= 2 fields
    Vector fine;
    T.prolongate(coarse, fine);
    const Vector expected = h.model(l).interpolate(field);
    if (l >= 2) CHECK((fine - expected).lpNorm<Eigen::Infinity>() < 1e-13);
    // Partition of unity: a constant maps to the same constant.
    Vector ones_c = Vector::Ones(T.coarse_size()), ones_f;
    T.prolongate(ones_c, ones_f);
    CHECK((ones_f - Vector::Ones(T.fine_size())).norm() < 1e-13);
  }
}

TEST_CASE("the seed's interpolating restriction inverts degree elevation", "[multigrid][transfer]") {
  DegreeHierarchy h(bar(), 3, Material{}, clamped);
  for (int l = 1; l < h.num_levels(); ++l) {
    const Eigen::MatrixXd RP = Eigen::MatrixXd(h.interpolating_restriction(l).to_eigen()) *
                               Eigen::MatrixXd(h.prolongation(l).to_eigen());
    CHECK((RP - Eigen::MatrixXd::Identity(RP.rows(), RP.cols())).norm() < 1e-13);
  }
}

TEST_CASE("Galerkin RAP equals the re-discretised operator to round-off (R = Pᵀ, same rotations)",
          "[multigrid][transfer][galerkin]") {
  DegreeHierarchy h(bar(), 3, Material{500e3, 0.3, 1000.0}, clamped);
  for (bool rotated : {false, true}) {
    const Rotations R = random_rotations(bar().num_tets(), 5);
    h.assemble(rotated ? &R : nullptr);
    for (int l = h.num_levels() - 1; l >= 1; --l) {
      const mg::BlockTransfer T(h.prolongation(l));
      const Bcsr G = mg::galerkin_product(T, h.matrix(l));
      const Eigen::MatrixXd dG = G.to_csr().to_eigen(), dA = h.matrix(l - 1).to_csr().to_eigen();
      INFO("level " << l << (rotated ? " with rotations" : " linear"));
      CHECK((dG - dA).norm() <= 1e-12 * dA.norm());
    }
  }
}

TEST_CASE("a kept Galerkin product refreshes values only and matches the sparse-product reference",
          "[multigrid][transfer][galerkin]") {
  DegreeHierarchy h(bar(), 3, Material{500e3, 0.3, 1000.0}, clamped);
  h.assemble(nullptr);
  for (int l = h.num_levels() - 1; l >= 1; --l) {
    for (bool interpolating : {false, true}) {
      const mg::BlockTransfer T = interpolating ? mg::BlockTransfer(h.prolongation(l), h.interpolating_restriction(l))
                                                : mg::BlockTransfer(h.prolongation(l));
      mg::GalerkinProduct G(T, h.matrix(l));
      const auto pattern = G.matrix().shared_pattern();
      for (unsigned seed : {1u, 2u}) {
        const Rotations R = random_rotations(bar().num_tets(), seed);
        h.assemble(&R, nullptr, 2.0, 0.5);  // new values, same pattern
        G.update(h.matrix(l));
        const Eigen::MatrixXd got = G.matrix().to_csr().to_eigen();
        const Eigen::MatrixXd ref = mg::galerkin_product(T, h.matrix(l)).to_csr().to_eigen();
        INFO("level " << l << (interpolating ? ", interpolating restriction" : ", R = Pᵀ") << ", seed " << seed);
        CHECK((got - ref).norm() <= 1e-13 * ref.norm());
        CHECK(G.matrix().shared_pattern() == pattern);  // the pattern object is kept
      }
    }
  }
  // A fine matrix of another pattern is refused.
  const mg::BlockTransfer T(h.prolongation(2));
  mg::GalerkinProduct G(T, h.matrix(2));
  DegreeHierarchy other(bar(), 3, Material{}, nothing);
  other.assemble(nullptr);
  CHECK_THROWS_AS(G.update(other.matrix(2)), InputError);
}
