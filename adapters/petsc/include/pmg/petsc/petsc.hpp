// pmg/petsc/petsc.hpp — PETSc's preconditioners beside hypre's, as a Solver: GAMG (smoothed
// aggregation with the rigid-body near-null space, the recipe FEniCSx gives for elasticity), and
// PETSc's Cholesky factorisations through MUMPS and CHOLMOD, and on a displacement–pressure saddle
// point PETSc's fieldsplit (a Schur-complement factorisation with GAMG on the displacement block and
// Jacobi on the scaled pressure mass: the iterative peer of mixed-gmres). The one PETSc adapter; built when
// PETSc is found (Debian's libpetsc-real-dev: scripts/setup.sh installs it), else the factory's
// gamg, gamg-pcg, mumps and petsc-cholmod methods say that PETSc is missing.
//
// The matrix is a PETSc AIJ matrix over our scalar CSR's column indices and values (no copy of
// them; the 64-bit row offsets are narrowed once to PETSc's 32-bit PetscInt), with block size 3.
// PETSc is initialised once per process after MPI (pmg/mpi/session.hpp) and finalised before it.
// Options beyond the keys below go through PETSc's options database under a prefix of this
// object's own ("options": "-pc_gamg_threshold 0.02 -mg_levels_ksp_max_it 3"), so two solvers of
// one run never share settings.
#pragma once

#include "pmg/sparse/config.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/saddle_point.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg::petsc {

/// The options of PetscPreconditioner (solver keys: see visit()).
struct PetscParams {
  /// "gamg": one GAMG V-cycle per apply (a fixed symmetric operator, for CG); "mumps" and
  /// "cholmod": PETSc's Cholesky factorisation by that package (a direct solve per apply);
  /// "fieldsplit": on a saddle point [A Bᵀ; B −C] (set_saddle_point), PCFIELDSPLIT's upper
  /// Schur factorisation, z_p = Ŝ⁻¹ r_p, z_u = GAMG(r_u − Bᵀ z_p), with Ŝ = −s M_p (the
  /// blocks' scaled pressure mass, as mixed-gmres) under one Jacobi sweep: a fixed nonsymmetric
  /// operator, for GMRES.
  std::string type = "gamg";
  /// gamg, the factory's key: "rigid" (the six rigid-body modes from node coordinates), "none"
  /// (PETSc's default, the constants of each of the 3 components) or "auto" (rigid where the
  /// coordinates are known); resolved into rigid_near_null_space.
  std::string near_null_space = "auto";
  /// gamg and fieldsplit: the rigid-body modes as the near-null space (set_coordinates before
  /// setup; fieldsplit: of the displacement block).
  bool rigid_near_null_space = true;
  /// Further PETSc options ("-name value ..."; "-pc_" and "-mg_" options of the PC), applied
  /// after the defaults, so they override them.
  std::string options;
  /// Accept options PETSc does not read (else setup() throws InputError naming them); the
  /// factory sets it from unused_keys (known or ignore).
  bool allow_unused_options = false;
  /// mumps: the system is symmetric indefinite (a saddle point): factorised as LDLᵀ with pivoting
  /// (MUMPS's sym = 2) instead of as SPD. Set by the factory where SolverContext::saddle_point is.
  bool indefinite = false;
  /// mumps and cholmod: how solve() checks (and refines) its answer.
  DirectSolveParams check;
  /// The keys near_null_space (gamg), options, and the check's (mumps, cholmod).
  void visit(ParamVisitor& v);
};

/// Whether this build has PETSc.
bool petsc_available();

/// Initialises PETSc (and MPI) now, once per process (the methods' start-up hook); nothing
/// without PETSc.
void start_petsc();

/// A PETSc preconditioner (GAMG, or a Cholesky factorisation by MUMPS or CHOLMOD) as a Solver (see
/// the file comment).
class PetscPreconditioner final : public Solver {
 public:
  /// Not yet set up. Throws InputError for an unknown params.type, and in a build without PETSc
  /// always (saying that PETSc is missing).
  explicit PetscPreconditioner(const PetscParams& params = {});
  ~PetscPreconditioner() override;
  PetscPreconditioner(const PetscPreconditioner&) = delete;
  PetscPreconditioner& operator=(const PetscPreconditioner&) = delete;

  std::string name() const override { return params_.type == "cholmod" ? "petsc-cholmod" : params_.type; }
  /// The parameters given at construction.
  const PetscParams& params() const { return params_; }
  /// x, y, z per node (interleaved like the unknowns): the rigid-body modes of GAMG.
  void set_coordinates(std::vector<double> xyz) { coordinates_ = std::move(xyz); }
  /// fieldsplit: the saddle point's blocks (the pressure mass and its scale; the pressure is the
  /// last M_p.rows() unknowns), which must outlive the set-up.
  void set_saddle_point(const SaddlePointBlocks* blocks) { saddle_ = blocks; }
  /// The PETSc options in force; after set-up GAMG's levels and operator complexity, or the
  /// factorisation's ordering and nonzeros.
  std::string describe() const override;

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  void apply_impl(const Vector& r, Vector& z) const override;
  /// mumps and cholmod: solve() is a direct solve, checked as params().check says.
  const DirectSolveParams* direct_check() const override {
    return params_.type == "gamg" || params_.type == "fieldsplit" ? nullptr : &params_.check;
  }
  /// fieldsplit: the index sets, the near-null space of the displacement block and Ŝ, for a
  /// system of n unknowns.
  void set_up_fieldsplit(index_t n);
  /// fieldsplit: Ŝ's values, −s M_p, from the blocks' present scale.
  void scale_schur();
  struct Impl;
  std::unique_ptr<Impl> impl_;
  PetscParams params_;
  std::vector<double> coordinates_;
  const SaddlePointBlocks* saddle_ = nullptr;
  ScalarMatrix scalar_;
};

/// Registers the methods gamg-pcg, gamg, mumps, petsc-cholmod and fieldsplit-gmres (idempotent; a name the user
/// registered is kept). Without PETSc in the build they are registered too, and building one throws
/// InputError saying that PETSc is missing.
void register_solvers();

}  // namespace pmg::petsc

namespace pmg::mg {
/// The adapter's names before it moved to its folder's namespace (pmgkit 0.2); kept for callers.
using petsc::petsc_available;
using petsc::PetscParams;
using petsc::PetscPreconditioner;
using petsc::start_petsc;
}  // namespace pmg::mg
