// petsc_reference — PETSc driven only by its own command line, on a system that `pmg compare
// --export-petsc DIR` wrote: the check that pmgkit's PETSc adapter drives GAMG, MUMPS and CHOLMOD
// the way PETSc's own users do (same iterations, comparable times).
//
//   build/bench/petsc/petsc_reference -dir DIR -ksp_type cg -pc_type gamg -ksp_rtol 1e-6
//       -ksp_norm_type unpreconditioned -mg_levels_ksp_type chebyshev -mg_levels_pc_type jacobi
//       -mg_levels_esteig_ksp_type cg [-near_null_space rigid|none] [-ksp_view]
//
// Reads DIR/A.petsc (MatLoad, block size 3), DIR/b.petsc and, for the rigid-body near-null space
// (the default), DIR/coordinates.petsc (MatNullSpaceCreateRigidBody). Solves from zero with
// KSPSetFromOptions and prints the iterations, the set-up and solve times and the true relative
// residual ||b - A x|| / ||b||.
#include <petscksp.h>

#include <chrono>
#include <cstdio>
#include <cstring>

namespace {
double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  char dir[PETSC_MAX_PATH_LEN] = ".", nns[16] = "rigid";
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-dir", dir, sizeof dir, nullptr));
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-near_null_space", nns, sizeof nns, nullptr));
  auto open = [&](const char* name, PetscViewer* v) {
    char path[PETSC_MAX_PATH_LEN + 32];
    std::snprintf(path, sizeof path, "%s/%s", dir, name);
    return PetscViewerBinaryOpen(PETSC_COMM_WORLD, path, FILE_MODE_READ, v);
  };
  Mat A;
  Vec b, x, r, coords = nullptr;
  PetscViewer v;
  PetscCall(open("A.petsc", &v));
  PetscCall(MatCreate(PETSC_COMM_WORLD, &A));
  PetscCall(MatSetType(A, MATAIJ));
  PetscCall(MatSetBlockSize(A, 3));
  PetscCall(MatLoad(A, v));
  PetscCall(PetscViewerDestroy(&v));
  PetscCall(MatSetOption(A, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(A, MAT_SPD, PETSC_TRUE));
  PetscCall(open("b.petsc", &v));
  PetscCall(VecCreate(PETSC_COMM_WORLD, &b));
  PetscCall(VecLoad(b, v));
  PetscCall(PetscViewerDestroy(&v));
  MatNullSpace ns = nullptr;
  if (std::strcmp(nns, "rigid") == 0) {
    PetscCall(open("coordinates.petsc", &v));
    PetscCall(VecCreate(PETSC_COMM_WORLD, &coords));
    PetscCall(VecSetBlockSize(coords, 3));
    PetscCall(VecLoad(coords, v));
    PetscCall(PetscViewerDestroy(&v));
    PetscCall(MatNullSpaceCreateRigidBody(coords, &ns));
    PetscCall(MatSetNearNullSpace(A, ns));
  }
  PetscCall(VecDuplicate(b, &x));
  PetscCall(VecDuplicate(b, &r));
  PetscCall(VecSet(x, 0.0));
  KSP ksp;
  PetscCall(KSPCreate(PETSC_COMM_WORLD, &ksp));
  PetscCall(KSPSetOperators(ksp, A, A));
  PetscCall(KSPSetFromOptions(ksp));
  auto t0 = std::chrono::steady_clock::now();
  PetscCall(KSPSetUp(ksp));
  const double setup = since(t0);
  t0 = std::chrono::steady_clock::now();
  PetscCall(KSPSolve(ksp, b, x));
  const double solve = since(t0);
  PetscInt its;
  KSPConvergedReason reason;
  PetscCall(KSPGetIterationNumber(ksp, &its));
  PetscCall(KSPGetConvergedReason(ksp, &reason));
  PetscReal bn, rn;
  PetscCall(MatMult(A, x, r));
  PetscCall(VecAYPX(r, -1.0, b));
  PetscCall(VecNorm(r, NORM_2, &rn));
  PetscCall(VecNorm(b, NORM_2, &bn));
  KSPType kt;
  PCType pt;
  PC pc;
  PetscCall(KSPGetType(ksp, &kt));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCGetType(pc, &pt));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD,
                        "petsc_reference: %s + %s (near-null space: %s): %s after %d iterations, set-up "
                        "%.4f s, solve %.4f s, total %.4f s, true relative residual %.3e\n",
                        kt, pt, ns ? "rigid-body modes" : "PETSc's default", KSPConvergedReasons[reason],
                        static_cast<int>(its), setup, solve, setup + solve, static_cast<double>(rn / bn)));
  PetscCall(KSPDestroy(&ksp));
  if (ns) PetscCall(MatNullSpaceDestroy(&ns));
  if (coords) PetscCall(VecDestroy(&coords));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&r));
  PetscCall(VecDestroy(&b));
  PetscCall(MatDestroy(&A));
  PetscCall(PetscFinalize());
  return reason > 0 ? 0 : 1;
}
