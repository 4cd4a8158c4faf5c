// pmg compare --distributed-mesh: a scene built on the MPI ranks from the start (DMPlex), no rank
// holding the whole model, solved by petsc-mgpcg (pmg/distributed/mesh_problem.hpp).
#pragma once

#include "scene.hpp"

#include "pmg/sparse/config.hpp"

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace pmg::tools {

/// Adds --distributed-mesh (into `flag`) and --save-mesh (into `save_mesh`) to pmg compare.
void add_distributed_mesh_options(CLI::App* sub, bool& flag, std::string& save_mesh);
/// With --distributed-mesh (`on`), refuses by name what it cannot honour: the options of `sub` it
/// does not take, methods other than petsc-mgpcg, a --save-mesh not in PETSc's HDF5 format
/// (.h5); without it, a --save-mesh.
void check_distributed_mesh(const CLI::App& sub, bool on, const std::vector<std::string>& solvers,
                            const std::string& save_mesh);

/// Builds the scene of `o` on the ranks of MPI_COMM_WORLD (rank 0 makes the coarse mesh, or every
/// rank reads a share of a `.h5` mesh in PETSc's HDF5 format; DMPlex distributes it, each rank
/// refines its part `o.refine` times; `out.save_mesh`: written there), solves it from zero with
/// petsc-mgpcg's keys in `solver` and prints each stage's time, the iterations, the true residual,
/// the compliance, the largest displacement and each rank's peak memory (rank 0 prints;
/// `out.json`: the same figures as JSON; `out.history`: the residual per iteration as
/// `pmg compare --history` writes it). Throws Exit{kSolveFailed} when the solve fails, InputError for bad
/// input (on every rank) or where the build has no PETSc.
/// Where --distributed-mesh writes (empty: not written).
struct DistributedMeshOutputs {
  std::string json;       ///< --json: the report
  std::string save_mesh;  ///< --save-mesh: the refined mesh in PETSc's HDF5 format
  std::string history;    ///< --history: the residual per iteration, as CSV
};

void run_distributed_mesh(const SceneOptions& o, const Config& solver, const DistributedMeshOutputs& out);

}  // namespace pmg::tools
