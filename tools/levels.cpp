#include "levels.hpp"

#include "pmg/sparse/file_io.hpp"

#include "pmg/sparse/matrix_market.hpp"
#include "pmg/sparse/petsc_binary.hpp"

#include <filesystem>
#include <iostream>

namespace pmg::tools {

void export_levels(FemSystem& system, const std::string& dir) {
  prepare_output_directory(dir, "--export-levels");
  system.assemble_lower_levels();
  const fem::DegreeHierarchy& h = system.hierarchy();
  for (int l = 0; l < h.num_levels(); ++l) {
    write_matrix_market(dir + "/A" + std::to_string(l) + ".mtx", h.matrix(l).to_csr(), true);
    if (l > 0) write_matrix_market(dir + "/P" + std::to_string(l) + ".mtx", h.prolongation(l));
  }
  write_matrix_market_vector(dir + "/b.mtx", system.b);
  std::cout << "levels: " << dir << "/A0.mtx .. A" << h.num_levels() - 1 << ".mtx (coarsest first), P1 .. P"
            << h.num_levels() - 1 << ".mtx, b.mtx\n";
}

void export_petsc(const FemSystem& system, const std::string& dir) {
  prepare_output_directory(dir, "--export-petsc");
  write_petsc_binary(dir + "/A.petsc", system.matrix().to_csr());
  write_petsc_binary(dir + "/b.petsc", system.b);
  const std::vector<double> xyz = system.free_coordinates();
  write_petsc_binary(dir + "/coordinates.petsc", Vector(Eigen::Map<const Vector>(xyz.data(), xyz.size())));
  std::cout << "PETSc binary: " << dir << "/A.petsc, b.petsc, coordinates.petsc\n";
}

}  // namespace pmg::tools
