// pmg/multigrid/levels.hpp — level hierarchies held in memory. The interface every hierarchy
// implements, mg::LevelProvider, is in the solver core (pmg/sparse/level_provider.hpp), so that a
// discretisation (pmg::fem) can offer levels without linking the multigrid library.
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/level_provider.hpp"

#include <string>
#include <vector>

namespace pmg::mg {

/// Levels owned in memory: matrices and prolongations handed over by value. Sizes are checked
/// (3 x nodes per level, prolongations nodes x nodes) with the level named.
class StoredLevels final : public LevelProvider {
 public:
  /// Level matrices coarsest first (square) and one scalar prolongation per level above the lowest
  /// (prolongations[l-1]: level l-1 to level l). Throws InputError naming the level whose sizes do
  /// not fit.
  StoredLevels(std::vector<Bcsr> matrices, std::vector<Csr> prolongations);
  int num_levels() const override { return static_cast<int>(matrices_.size()); }
  const Bcsr& matrix(int level) const override { return matrices_.at(level); }
  /// A level's matrix, writable: new values on the same pattern, then update() the solver.
  Bcsr& matrix(int level) { return matrices_.at(level); }
  const Csr& prolongation(int level) const override { return prolongations_.at(level - 1); }

 private:
  std::vector<Bcsr> matrices_;
  std::vector<Csr> prolongations_;
};

/// The levels of another provider from one of its levels up: level l here is the base's level
/// l + skip (its matrix, operators, transfers, patches and name). A cycle built on it takes the
/// base's level `skip` as its lowest (the factory's skip_levels): on a BB hierarchy, skip 1
/// makes degree 2 the factorised lowest level. The base must outlive the view.
class LevelsFrom final : public LevelProvider {
 public:
  /// Throws InputError unless 0 <= skip < base.num_levels().
  LevelsFrom(const LevelProvider& base, int skip);
  int num_levels() const override { return base_.num_levels() - skip_; }
  const Bcsr& matrix(int level) const override { return base_.matrix(level + skip_); }
  const Csr& prolongation(int level) const override { return base_.prolongation(level + skip_); }
  Csr interpolating_restriction(int level) const override { return base_.interpolating_restriction(level + skip_); }
  bool has_matrix(int level) const override { return base_.has_matrix(level + skip_); }
  const LinearOperator* matrix_free_operator(int level) const override {
    return base_.matrix_free_operator(level + skip_);
  }
  bool offers_matrix_free() const override;
  std::vector<double> node_coordinates(int level) const override { return base_.node_coordinates(level + skip_); }
  const std::vector<char>* constrained_dofs(int level) const override { return base_.constrained_dofs(level + skip_); }
  const std::vector<std::vector<index_t>>* vertex_patches(int level) const override {
    return base_.vertex_patches(level + skip_);
  }
  double lame_ratio() const override { return base_.lame_ratio(); }
  std::string level_name(int level) const override { return base_.level_name(level + skip_); }
  /// The base's level behind level 0.
  int skip() const { return skip_; }

 private:
  const LevelProvider& base_;
  int skip_;
};

}  // namespace pmg::mg
