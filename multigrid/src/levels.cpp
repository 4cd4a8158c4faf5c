#include "pmg/multigrid/levels.hpp"

namespace pmg::mg {

StoredLevels::StoredLevels(std::vector<Bcsr> matrices, std::vector<Csr> prolongations)
    : matrices_(std::move(matrices)), prolongations_(std::move(prolongations)) {
  if (matrices_.empty()) throw InputError("multigrid levels: no level matrices");
  if (prolongations_.size() + 1 != matrices_.size())
    throw InputError("multigrid levels: " + std::to_string(matrices_.size()) + " levels need " +
                     std::to_string(matrices_.size() - 1) + " prolongations, got " +
                     std::to_string(prolongations_.size()));
  for (size_t l = 0; l < matrices_.size(); ++l)
    if (matrices_[l].block_rows() != matrices_[l].block_cols())
      throw InputError("multigrid levels: level " + std::to_string(l) + " is not square");
  for (size_t l = 1; l < matrices_.size(); ++l) {
    const Csr& P = prolongations_[l - 1];
    if (P.rows() != matrices_[l].block_rows() || P.cols() != matrices_[l - 1].block_rows())
      throw InputError("multigrid levels: prolongation " + std::to_string(l) + " is " +
                       std::to_string(P.rows()) + "x" + std::to_string(P.cols()) + ", levels " +
                       std::to_string(l - 1) + " and " + std::to_string(l) + " need " +
                       std::to_string(matrices_[l].block_rows()) + "x" +
                       std::to_string(matrices_[l - 1].block_rows()) + " (nodes)");
  }
}

LevelsFrom::LevelsFrom(const LevelProvider& base, int skip) : base_(base), skip_(skip) {
  if (skip < 0 || skip >= base.num_levels())
    throw InputError("multigrid: skip_levels=" + std::to_string(skip) + " leaves no level of " +
                     std::to_string(base.num_levels()));
}

// The base's operators cover its levels above its lowest, which include every level above this
// view's lowest.
bool LevelsFrom::offers_matrix_free() const { return num_levels() >= 2 && base_.offers_matrix_free(); }

}  // namespace pmg::mg
