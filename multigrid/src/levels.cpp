#include "pmg/multigrid/levels.hpp"

#include "pmg/sparse/matrix_market.hpp"

namespace pmg::mg {

Csr LevelProvider::interpolating_restriction(int level) const {
  throw InputError("these multigrid levels define no interpolating restriction (level " +
                   std::to_string(level) + "); use the transposed prolongation");
}

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

StoredLevels read_levels(const std::vector<std::string>& matrix_files,
                         const std::vector<std::string>& prolongation_files) {
  if (matrix_files.size() < 2) throw InputError("multigrid levels: need at least two matrices (coarsest first)");
  if (prolongation_files.size() + 1 != matrix_files.size())
    throw InputError(std::to_string(matrix_files.size()) + " levels need " +
                     std::to_string(matrix_files.size() - 1) + " prolongations, got " +
                     std::to_string(prolongation_files.size()));
  std::vector<Bcsr> matrices;
  for (const auto& path : matrix_files) {
    const Csr A = read_matrix_market(path);
    if (A.rows() != A.cols() || A.rows() % 3 != 0)
      throw InputError(path + ": a level matrix must be square with 3 unknowns per node");
    if (!A.is_symmetric(1e-12)) throw InputError(path + ": a level matrix must be symmetric");
    matrices.push_back(Bcsr::from_csr(A));
  }
  std::vector<Csr> prolongations;
  for (size_t l = 1; l < matrix_files.size(); ++l) {
    Csr P = read_matrix_market(prolongation_files[l - 1]);
    if (3 * P.rows() != matrices[l].rows() || 3 * P.cols() != matrices[l - 1].rows())
      throw InputError(prolongation_files[l - 1] + ": prolongation is " + std::to_string(P.rows()) +
                       "x" + std::to_string(P.cols()) + ", levels need " +
                       std::to_string(matrices[l].rows() / 3) + "x" +
                       std::to_string(matrices[l - 1].rows() / 3) + " (nodes)");
    prolongations.push_back(std::move(P));
  }
  return StoredLevels(std::move(matrices), std::move(prolongations));
}

}  // namespace pmg::mg
