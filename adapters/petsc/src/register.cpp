// The PETSc adapter's factory methods (with or without PETSc in the build: see petsc_missing.cpp).
#include "pmg/petsc/petsc.hpp"
#include "pmg/sparse/factory.hpp"

#include <mutex>

namespace pmg::petsc {

void PetscParams::visit(ParamVisitor& v) {
  if (type == "gamg" || type == "fieldsplit")
    v.choice("near_null_space", near_null_space, {"auto", "rigid", "none"},
             "rigid: the six rigid-body modes from node coordinates; none: PETSc's default (constants); "
             "auto: rigid where coordinates are known");
  v.text("options", options, "further PETSc options (\"-name value ...\"), under this solver's own prefix");
  if (type != "gamg" && type != "fieldsplit") check.visit(v);
}

}  // namespace pmg::petsc

namespace pmg::petsc {

namespace {

/// A PETSc preconditioner (GAMG, or a Cholesky factorisation by MUMPS or CHOLMOD).
std::unique_ptr<PetscPreconditioner> make(const Config& c, const SolverContext& ctx, const std::string& type) {
  PetscParams p;
  p.type = type;
  p = read_params(c, p);
  p.allow_unused_options = unused_options_allowed(c);
  if (p.near_null_space == "rigid" && !ctx.coordinates)
    c.fail("near_null_space", "rigid needs node coordinates: an FEM scene (--box or --mesh) provides "
                              "them; a matrix read from a file does not (auto: rigid where known)");
  p.rigid_near_null_space = type == "gamg" && p.near_null_space != "none" && ctx.coordinates;
  if (type == "fieldsplit") p.rigid_near_null_space = p.near_null_space != "none" && ctx.coordinates;
  if (ctx.saddle_point && type != "mumps" && type != "fieldsplit")
    c.fail("method", "PETSc " + type + " needs a symmetric positive definite system; a saddle point takes "
                     "fieldsplit-gmres, mumps (LDLᵀ), mixed-gmres or mixed-minres");
  if (type == "fieldsplit" && !ctx.saddle_point)
    c.fail("method", "fieldsplit-gmres solves a displacement-pressure saddle point: use it with formulation=mixed");
  p.indefinite = ctx.saddle_point != nullptr;
  auto s = std::make_unique<PetscPreconditioner>(p);
  if (p.rigid_near_null_space) s->set_coordinates(*ctx.coordinates);
  s->set_saddle_point(ctx.saddle_point);
  return s;
}

std::vector<KeyInfo> keys(const std::string& type) {
  PetscParams p;
  p.type = type;
  return list_params(p);
}

}  // namespace

void register_solvers() {
  static std::once_flag once;
  std::call_once(once, [] {
    std::function<void()> start;
    if (petsc_available()) start = [] { start_petsc(); };
    register_builtin_solver({"gamg-pcg", "CG preconditioned by PETSc's GAMG (smoothed aggregation, rigid-body near-null space)",
                     krylov_keys() + keys("gamg"), false, false, "petsc", start},
                    [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                      const KrylovParams k = read_krylov(c);
                      return std::make_unique<Cg>(k, make(c, ctx, "gamg"));
                    });
    register_builtin_solver({"gamg", "PETSc GAMG V-cycles (a fixed symmetric operator)", keys("gamg"), false, false, "petsc",
                     start},
                    [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                      return make(c, ctx, "gamg");
                    });
    register_builtin_solver({"mumps", "sparse Cholesky by MUMPS, through PETSc", keys("mumps"), false, false, "petsc", start},
                    [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                      return make(c, ctx, "mumps");
                    });
    register_builtin_solver({"fieldsplit-gmres",
                             "GMRES preconditioned by PETSc's fieldsplit on a displacement-pressure saddle point: upper "
                             "Schur factorisation, GAMG on the displacement block, Jacobi on the scaled pressure mass "
                             "(the iterative peer of mixed-gmres)",
                             krylov_keys() + keys("fieldsplit") + list_params<GmresParams>(), false, false, "petsc",
                             start},
                            [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                              const KrylovParams k = read_krylov(c);
                              const GmresParams g = read_params<GmresParams>(c);
                              return std::make_unique<Gmres>(k, make(c, ctx, "fieldsplit"), g);
                            });
    register_builtin_solver({"petsc-cholmod", "sparse Cholesky by CHOLMOD, through PETSc (to compare with the cholmod adapter)",
                     keys("cholmod"), false, false, "petsc", start},
                    [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                      return make(c, ctx, "cholmod");
                    });
  });
}

}  // namespace pmg::petsc
