#include "levels.hpp"

#include "pmg/sparse/matrix_market.hpp"

#include <filesystem>
#include <iostream>

namespace pmg::tools {

UserLevels read_levels(const std::vector<std::string>& matrices,
                       const std::vector<std::string>& prolongations) {
  if (matrices.size() < 2) throw InputError("--levels needs at least two matrices (coarsest first)");
  if (prolongations.size() + 1 != matrices.size())
    throw InputError(std::to_string(matrices.size()) + " levels need " +
                     std::to_string(matrices.size() - 1) + " prolongations, got " +
                     std::to_string(prolongations.size()));
  UserLevels u;
  for (const auto& path : matrices) {
    const Csr A = read_matrix_market(path);
    if (A.rows() != A.cols() || A.rows() % 3 != 0)
      throw InputError(path + ": a level matrix must be square with 3 unknowns per node");
    if (!A.is_symmetric(1e-12)) throw InputError(path + ": a level matrix must be symmetric");
    u.matrices.push_back(Bcsr::from_csr(A));
  }
  for (size_t l = 1; l < matrices.size(); ++l) {
    Csr P = read_matrix_market(prolongations[l - 1]);
    if (3 * P.rows() != u.matrices[l].rows() || 3 * P.cols() != u.matrices[l - 1].rows())
      throw InputError(prolongations[l - 1] + ": prolongation is " + std::to_string(P.rows()) + "x" +
                       std::to_string(P.cols()) + ", levels need " +
                       std::to_string(u.matrices[l].rows() / 3) + "x" +
                       std::to_string(u.matrices[l - 1].rows() / 3) + " (nodes)");
    u.transfers.push_back(std::make_unique<mg::BlockTransfer>(std::move(P)));
  }
  return u;
}

std::unique_ptr<mg::MultigridCycle> make_cycle(const UserLevels& levels,
                                               const fem::PmgOptions& options) {
  std::vector<const Bcsr*> matrices;
  std::vector<const mg::BlockTransfer*> transfers;
  std::vector<std::unique_ptr<mg::Smoother>> smoothers;
  for (size_t l = 0; l < levels.matrices.size(); ++l) {
    matrices.push_back(&levels.matrices[l]);
    if (l > 0) {
      transfers.push_back(levels.transfers[l - 1].get());
      smoothers.push_back(std::make_unique<mg::BlockGaussSeidel>(levels.matrices[l], options.smoother));
    }
  }
  return std::make_unique<mg::MultigridCycle>(matrices, transfers, std::move(smoothers),
                                              mg::make_lowest_level(levels.matrices[0], options.lowest_level,
                                                                    options.boomeramg, options.lowest_level_tol),
                                              options.cycle);
}

void set_lowest_level(fem::PmgOptions& options, const std::string& name, int amg_cycles, double tol) {
  if (name == "cholmod") options.lowest_level = mg::LowestLevel::cholmod;
  else if (name == "boomeramg") options.lowest_level = mg::LowestLevel::boomeramg;
  else if (name == "boomeramg-pcg") options.lowest_level = mg::LowestLevel::boomeramg_pcg;
  else throw InputError("unknown lowest-level solver '" + name + "' (cholmod, boomeramg, boomeramg-pcg)");
  options.boomeramg.cycles = amg_cycles;
  options.lowest_level_tol = tol;
}

void export_levels(FemSystem& system, const std::string& dir) {
  std::filesystem::create_directories(dir);
  system.assemble_lower_levels();
  const fem::DegreeHierarchy& h = *system.hierarchy;
  for (int l = 0; l < h.num_levels(); ++l) {
    write_matrix_market(dir + "/A" + std::to_string(l) + ".mtx", h.matrix(l).to_csr(), true);
    if (l > 0) write_matrix_market(dir + "/P" + std::to_string(l) + ".mtx", h.prolongation(l));
  }
  write_matrix_market_vector(dir + "/b.mtx", system.b);
  std::cout << "levels: " << dir << "/A0.mtx .. A" << h.num_levels() - 1 << ".mtx (coarsest first), P1 .. P"
            << h.num_levels() - 1 << ".mtx, b.mtx\n";
}

}  // namespace pmg::tools
