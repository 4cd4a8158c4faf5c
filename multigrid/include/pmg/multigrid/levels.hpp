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


}  // namespace pmg::mg
