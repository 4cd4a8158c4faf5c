# The baselines through the tools: BoomerAMG's settings reported and settable, the rigid-body
# interpolation vectors, the settings sweep, and PETSc's GAMG / MUMPS / CHOLMOD where PETSc is built
# (or the message that says it is not). All start MPI: leak detection off (tests/multigrid).
add_test(NAME "tools: pmg compare prints BoomerAMG's settings, levels and complexities"
  COMMAND ${EXPECT} 0 "boomeramg-pcg: BoomerAMG .*p_max=6 .*agg_levels=1 .*operator complexity"
    ${PMG} compare --box 4 1 1 -p 2 --solvers boomeramg-pcg)
add_test(NAME "tools: BoomerAMG with rigid-body interpolation vectors from the scene's nodes"
  COMMAND ${EXPECT} 0 "boomeramg-pcg +converged"
    ${PMG} compare --box 4 1 1 -p 2 --solvers boomeramg-pcg --set nodal=4 interp_vectors=rigid interp_vec_variant=1)
add_test(NAME "tools: BoomerAMG rigid-body vectors without node coordinates are named"
  COMMAND ${EXPECT} 2 "interp_vectors: rigid needs node coordinates"
    ${PMG} compare --grid 4 --solvers boomeramg-pcg --set nodal=4 interp_vectors=rigid)
add_test(NAME "tools: a BoomerAMG option out of range is named"
  COMMAND ${EXPECT} 2 "relax_order" ${PMG} compare --box 2 1 1 -p 2 --solvers boomeramg-pcg --set relax_order=7)
add_test(NAME "tools: amg_sweep.py tabulates BoomerAMG settings on one system"
  COMMAND ${EXPECT} 0 "\\| nodal=4 \\| converged \\|"
    /usr/bin/python3 ${CMAKE_SOURCE_DIR}/tools/amg_sweep.py --pmg ${PMG} --vary nodal=0,4 -- --box 4 1 1 -p 2)
set(pmg_baseline_tests
  "tools: pmg compare prints BoomerAMG's settings, levels and complexities"
  "tools: BoomerAMG with rigid-body interpolation vectors from the scene's nodes"
  "tools: BoomerAMG rigid-body vectors without node coordinates are named"
  "tools: a BoomerAMG option out of range is named"
  "tools: amg_sweep.py tabulates BoomerAMG settings on one system")
if(PMG_HAVE_PETSC)
  add_test(NAME "tools: pmg compare runs PETSc's GAMG, MUMPS and CHOLMOD beside ours"
    COMMAND ${EXPECT} 0 "mumps +converged .*e-1[0-9]"
      ${PMG} compare --box 4 1 1 -p 2 --solvers cholmod,petsc-cholmod,mumps,gamg-pcg)
  add_test(NAME "tools: gamg-pcg takes as many iterations as PETSc's own KSP on the exported system"
    COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/petsc_reference.sh ${PMG} $<TARGET_FILE:petsc_reference>)
  add_test(NAME "tools: a bad PETSc option value is named"
    COMMAND ${EXPECT} 1 "PETSc: .*abc" ${PMG} compare --box 2 1 1 -p 2 --solvers gamg-pcg --set "options=-pc_gamg_threshold abc")
  list(APPEND pmg_baseline_tests
    "tools: pmg compare runs PETSc's GAMG, MUMPS and CHOLMOD beside ours"
    "tools: gamg-pcg takes as many iterations as PETSc's own KSP on the exported system"
    "tools: a bad PETSc option value is named")
else()
  add_test(NAME "tools: PETSc's methods say that PETSc is missing"
    COMMAND ${EXPECT} 2 "need PETSc.*libpetsc-real-dev" ${PMG} compare --box 2 1 1 -p 2 --solvers gamg-pcg)
  list(APPEND pmg_baseline_tests "tools: PETSc's methods say that PETSc is missing")
endif()
set_tests_properties(${pmg_baseline_tests}
  PROPERTIES LABELS "tools" ENVIRONMENT "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1")
