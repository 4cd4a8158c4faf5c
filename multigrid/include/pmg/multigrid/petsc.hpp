// pmg/multigrid/petsc.hpp — PETSc's preconditioners beside hypre's, as a Solver: GAMG (smoothed
// aggregation with the rigid-body near-null space, the recipe FEniCSx gives for elasticity), and
// PETSc's Cholesky factorisations through MUMPS and CHOLMOD. The one PETSc adapter; built when
// PETSc is found (Debian's libpetsc-real-dev: scripts/setup.sh installs it), else the factory's
// gamg, gamg-pcg, mumps and petsc-cholmod methods say that PETSc is missing.
//
// The matrix is a PETSc AIJ matrix over our scalar CSR's column indices and values (no copy of
// them; the 64-bit row offsets are narrowed once to PETSc's 32-bit PetscInt), with block size 3.
// PETSc is initialised once per process after MPI (hypre's session) and finalised before it.
// Options beyond the keys below go through PETSc's options database under a prefix of this
// object's own ("options": "-pc_gamg_threshold 0.02 -mg_levels_ksp_max_it 3"), so two solvers of
// one run never share settings.
#pragma once

#include "pmg/sparse/config.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg::mg {

struct PetscParams {
  /// "gamg": one GAMG V-cycle per apply (a fixed symmetric operator, for CG); "mumps" and
  /// "cholmod": PETSc's Cholesky factorisation by that package (a direct solve per apply).
  std::string type = "gamg";
  /// gamg: the six rigid-body modes from node coordinates as the near-null space (else PETSc's
  /// default, the constants of each of the 3 components).
  bool rigid_near_null_space = true;
  /// Further PETSc options ("-name value ..."; "-pc_" and "-mg_" options of the PC), applied
  /// after the defaults, so they override them.
  std::string options;
};

/// Whether this build has PETSc.
bool petsc_available();

/// When a solver configuration uses PETSc (a method gamg, gamg-pcg, mumps or petsc-cholmod anywhere
/// in it), initialises PETSc (and MPI) now, before a caller's clocks, and returns the seconds it
/// took; otherwise returns a negative number.
double start_petsc(const Config& config);

class PetscPreconditioner final : public Solver {
 public:
  explicit PetscPreconditioner(const PetscParams& params = {});
  ~PetscPreconditioner() override;
  PetscPreconditioner(const PetscPreconditioner&) = delete;
  PetscPreconditioner& operator=(const PetscPreconditioner&) = delete;

  std::string name() const override { return "petsc-" + params_.type; }
  const PetscParams& params() const { return params_; }
  /// x, y, z per node (interleaved like the unknowns): the rigid-body modes of GAMG.
  void set_coordinates(std::vector<double> xyz) { coordinates_ = std::move(xyz); }
  /// The PETSc options in force; after set-up GAMG's levels and operator complexity, or the
  /// factorisation's ordering and nonzeros.
  std::string describe() const override;

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  void apply_impl(const Vector& r, Vector& z) const override;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  PetscParams params_;
  std::vector<double> coordinates_;
  ScalarMatrix scalar_;
};

}  // namespace pmg::mg
