# Hostile and careless input (issue #16): each finding of the fuzzing and bad-command-line campaign
# has a regression test here — a clear "pmg: error:" line naming what is wrong and a non-zero exit,
# never an abort, a hang or silent garbage. The reader inputs live in tests/fuzz/corpus/, which the
# fuzz replay tests (ctest -L fuzz) also run through the readers directly.
set(CORPUS ${CMAKE_SOURCE_DIR}/tests/fuzz/corpus)

# 1-5: the Gmsh and STL readers on blank-looking lines and unchecked counts.
add_test(NAME "hostile: #1 a Gmsh file of only a vertical tab is not a mesh"
  COMMAND ${EXPECT} 2
  "crash-01-vertical-tab-file.msh: no .MeshFormat section" ${PMG} mesh ${CORPUS}/gmsh/crash-01-vertical-tab-file.msh)
add_test(NAME "hostile: #1 a Gmsh line of only a form feed is blank"
  COMMAND ${EXPECT} 2
  "crash-01-form-feed-line.msh: no tetrahedra" ${PMG} mesh ${CORPUS}/gmsh/crash-01-form-feed-line.msh)
add_test(NAME "hostile: #1 a Gmsh file of carriage returns is not a mesh"
  COMMAND ${EXPECT} 2
  "no .MeshFormat section" ${PMG} mesh ${CORPUS}/gmsh/crash-01-carriage-returns.msh)
add_test(NAME "hostile: #2 a blank Gmsh 2.2 node count is named"
  COMMAND ${EXPECT} 2
  "crash-02-v22-blank-node-count.msh:6: file ends where the node count was expected" ${PMG} mesh ${CORPUS}/gmsh/crash-02-v22-blank-node-count.msh)
add_test(NAME "hostile: #3 a negative Gmsh 4.1 node count is named"
  COMMAND ${EXPECT} 2
  "crash-03-v41-negative-node-count.msh:6: negative node count -1" ${PMG} mesh ${CORPUS}/gmsh/crash-03-v41-negative-node-count.msh)
add_test(NAME "hostile: #3 a Gmsh 4.1 node count of 1e9 allocates nothing"
  COMMAND ${EXPECT} 2
  "node count 1000000000 is more than the 0 the rest of the file could hold" ${PMG} mesh ${CORPUS}/gmsh/crash-03-v41-node-count-1e9.msh)
add_test(NAME "hostile: #3 a Gmsh 4.1 node count of 1e11 allocates nothing"
  COMMAND ${EXPECT} 2
  "node count 100000000000 is more than" ${PMG} mesh ${CORPUS}/gmsh/crash-03-v41-node-count-1e11.msh)
add_test(NAME "hostile: #4 a negative Gmsh 2.2 tag count is named"
  COMMAND ${EXPECT} 2
  "crash-04-v22-negative-tag-count.msh:13: negative tag count -4" ${PMG} mesh ${CORPUS}/gmsh/crash-04-v22-negative-tag-count.msh)
add_test(NAME "hostile: #5 an STL line of only a form feed is blank"
  COMMAND ${EXPECT} 2
  "crash-05-form-feed-line.stl: no triangles" ${PMG} mesh ${CORPUS}/stl/crash-05-form-feed-line.stl)
add_test(NAME "hostile: #5 an STL facet with a vertical-tab line is named"
  COMMAND ${EXPECT} 2
  "crash-05-vertical-tab-line.stl:4: a facet must have 3 vertices" ${PMG} mesh ${CORPUS}/stl/crash-05-vertical-tab-line.stl)
# 6: an OFF face size that would overflow.
add_test(NAME "hostile: #6 an OFF face size of 2^63-1 is checked against its line"
  COMMAND ${EXPECT} 2
  "crash-06-face-size-overflow.off:6: face size 9223372036854775807 is more than the 3 vertex indices on the line"
  ${PMG} mesh ${CORPUS}/off/crash-06-face-size-overflow.off)
# 7: a scene number beyond double range.
add_test(NAME "hostile: #7 a scene number beyond double range names its key"
  COMMAND ${EXPECT} 2
  "crash-07-number-beyond-double.json: material.young: a number outside the range of a double"
  ${PMG} simulate ${CORPUS}/scene/crash-07-number-beyond-double.json)
add_test(NAME "hostile: fuzzing found: a solver key below a value's name is refused, not an abort in --print-scene"
  COMMAND ${EXPECT} 2 "crash-fuzz-method-value-and-section.json: solver: 'method.method.rerations' reaches below 'method.method'"
  ${PMG} simulate --print-scene ${CORPUS}/scene/crash-fuzz-method-value-and-section.json)
# 8-9: Matrix Market sizes the data does not back; an embedded NUL.
add_test(NAME "hostile: #8 a Matrix Market file declaring 1e8 rows for one entry allocates nothing"
  COMMAND ${EXPECT} 2
  "crash-08-declared-1e8-rows.mtx:2: declares 100000000 rows but only 1 entries"
  ${PMG} compare --matrix ${CORPUS}/matrix_market/crash-08-declared-1e8-rows.mtx --format csr --solvers cg)
add_test(NAME "hostile: #8 a Matrix Market file declaring 2^31-1 rows allocates nothing"
  COMMAND ${EXPECT} 2
  "declares 2147483647 rows but only 1 entries"
  ${PMG} compare --matrix ${CORPUS}/matrix_market/crash-08-declared-2e31-rows.mtx --format csr --solvers cg)
add_test(NAME "hostile: #8 a Matrix Market array declaring 1e8 values is checked against the file"
  COMMAND ${EXPECT} 2
  "declares 100000000 x 1 values, more than the rest of the file can hold"
  ${PMG} compare --matrix ${DATA}/spd.mtx --rhs ${CORPUS}/matrix_market/crash-08-declared-1e8-array.mtx --format csr --solvers cg)
add_test(NAME "hostile: fuzzing found: an array of 1e8 rows and no columns allocates nothing"
  COMMAND ${EXPECT} 2 "crash-fuzz-array-zero-columns-1e8-rows.mtx:2: declares 100000000 rows but only 0 entries"
  ${PMG} compare --matrix ${CORPUS}/matrix_market/crash-fuzz-array-zero-columns-1e8-rows.mtx --format csr --solvers cg)
add_test(NAME "hostile: review found: repeated Matrix Market entries summing to infinity are refused"
  COMMAND ${EXPECT} 2 "crash-review-repeated-entries-overflow.mtx: the repeated entries at .1, 1. sum to a non-finite value"
  ${PMG} compare --matrix ${CORPUS}/matrix_market/crash-review-repeated-entries-overflow.mtx --format csr --solvers cg)
add_test(NAME "hostile: #9 an embedded NUL inside a number is refused"
  COMMAND ${EXPECT} 2
  "crash-09-embedded-nul.mtx:3: expected a real value, found '2.x00junk'"
  ${PMG} compare --matrix ${CORPUS}/matrix_market/crash-09-embedded-nul.mtx --format csr --solvers cg)
# 10: output folders that cannot be made.
add_test(NAME "hostile: #10 --export-levels under /proc is refused before any work"
  COMMAND ${EXPECT} 2
  "--export-levels /proc/x: cannot create the folder" ${PMG} compare --box 2 1 1 -p 2 --solvers cg --export-levels /proc/x)
add_test(NAME "hostile: #10 --export-levels under a file is refused before any work"
  COMMAND sh -c
  "d=$(mktemp -d) && touch $d/f && ${EXPECT} 2 'export-levels .*/f/sub: cannot create the folder' $<TARGET_FILE:pmg> compare --box 2 1 1 -p 2 --solvers cg --export-levels $d/f/sub; rc=$?; rm -rf $d; exit $rc")
# 11: durations that overflow the step count or are not numbers.
add_test(NAME "hostile: #11 simulate --duration 1e300 is refused with the step count"
  COMMAND ${EXPECT} 2
  "--duration: duration 1e.300 s at dt 0.01 s is 1e.302 steps, more than 1e.07" ${PMG} simulate --duration 1e300)
add_test(NAME "hostile: #11 simulate --duration nan is refused"
  COMMAND ${EXPECT} 2
  "--duration: 'nan' is not a finite number" ${PMG} simulate --duration nan)
add_test(NAME "hostile: #11 simulate --duration shorter than half a step is refused"
  COMMAND ${EXPECT} 2
  "--duration: duration 0.001 s is shorter than half a step" ${PMG} simulate --duration 0.001)
# 12: sizes beyond the machine.
add_test(NAME "hostile: #12 a scene box of 1000^3 boxes is refused before it is built"
  COMMAND sh -c
  "d=$(mktemp -d) && echo '{\"mesh\": {\"box\": [1000, 1000, 1000]}}' > $d/s.json && ${EXPECT} 2 '2.4e.10 tetrahedra of degree 3: more elements than a 32-bit index' $<TARGET_FILE:pmg> simulate $d/s.json; rc=$?; rm -rf $d; exit $rc")
add_test(NAME "hostile: #12 a scene whose memory estimate exceeds the machine is refused with the estimate"
  COMMAND sh -c
  "d=$(mktemp -d) && echo '{\"mesh\": {\"box\": [200, 200, 200]}}' > $d/s.json && ${EXPECT} 2 '1.92e.08 tetrahedra of degree 3 would need an estimated 9600.0 GB of memory; this machine has' $<TARGET_FILE:pmg> simulate $d/s.json; rc=$?; rm -rf $d; exit $rc")
add_test(NAME "hostile: #12 compare --grid 400 is refused with its memory estimate"
  COMMAND ${EXPECT} 2 "--grid 400 .6.4e.07 nodes. would need an estimated 512.0 GB of memory" ${PMG} compare --grid 400 --solvers cg)
add_test(NAME "hostile: #12 compare --box beyond 1000 boxes is refused"
  COMMAND ${EXPECT} 2
  "--box: Value 5000 not in range 1 to 1000" ${PMG} compare --box 5000 1 1 --solvers cg)
# 13: tangled and cracked meshes.
add_test(NAME "hostile: #13 a tangled mesh names the two overlapping elements"
  COMMAND ${EXPECT} 2
  "tangled.ele: element 1 and element 0 lie on the same side of their shared face .0, 1, 3.: the mesh is tangled"
  ${PMG} mesh ${DATA}/tangled.ele)
add_test(NAME "hostile: #13 a cracked mesh names the coincident vertices"
  COMMAND ${EXPECT} 2
  "cracked.ele: vertices 0 and 6 lie at the same point .*: the mesh is cracked" ${PMG} mesh ${DATA}/cracked.ele)
add_test(NAME "hostile: #13 a tangled mesh given to compare is refused"
  COMMAND ${EXPECT} 2
  "the mesh is tangled" ${PMG} compare --mesh ${DATA}/tangled.ele -p 2 --fix z --fix-fraction 0.5 --solvers cholmod)
add_test(NAME "hostile: #13 --allow cracked accepts a cracked mesh on purpose"
  COMMAND ${EXPECT} 0
  "mesh: 4 tetrahedra, 8 vertices" ${PMG} mesh ${DATA}/cracked.ele --allow cracked)
add_test(NAME "hostile: #13 --allow tangled accepts a tangled mesh on purpose"
  COMMAND ${EXPECT} 0
  "mesh: 4 tetrahedra, 6 vertices" ${PMG} mesh ${DATA}/tangled.ele --allow tangled)
# 14: impossible option values and duplicate keys.
add_test(NAME "hostile: #14 compare --tol nan is refused"
  COMMAND ${EXPECT} 2 "--tol: 'nan' is not a finite number" ${PMG} compare --grid 4 --tol nan)
add_test(NAME "hostile: #14 compare --tol 2 is refused"
  COMMAND ${EXPECT} 2 "--tol: '2' is outside .0 - 1." ${PMG} compare --grid 4 --tol 2)
add_test(NAME "hostile: #14 compare --threads 0 is refused"
  COMMAND ${EXPECT} 2 "--threads: Value 0 not in range 1 to 1024" ${PMG} compare --grid 4 --threads 0)
add_test(NAME "hostile: #14 simulate --threads -3 is refused"
  COMMAND ${EXPECT} 2 "--threads: Value -3 not in range 1 to 1024" ${PMG} simulate --threads -3)
add_test(NAME "hostile: #14 compare --young nan is refused"
  COMMAND ${EXPECT} 2 "--young: 'nan' is not a finite number" ${PMG} compare --box 2 1 1 --young nan)
add_test(NAME "hostile: #14 a duplicate scene key is named"
  COMMAND ${EXPECT} 2
  "crash-14-duplicate-key.json: key 'degree' appears twice" ${PMG} simulate ${CORPUS}/scene/crash-14-duplicate-key.json)
add_test(NAME "hostile: #14 a duplicate nested key in --solver-config is named with its path"
  COMMAND sh -c
  "d=$(mktemp -d) && echo '{\"a\": {\"method\": \"cg\", \"tol\": 1e-6, \"tol\": 1e-8}}' > $d/c.json && ${EXPECT} 2 \"key 'a.tol' appears twice\" $<TARGET_FILE:pmg> compare --grid 4 --solver-config $d/c.json; rc=$?; rm -rf $d; exit $rc")
# 15: output paths checked before the work.
add_test(NAME "hostile: #15 compare --history under a missing folder is refused before any solve"
  COMMAND ${EXPECT} 2
  "--history /proc/x/h.csv: folder /proc/x does not exist" ${PMG} compare --grid 4 --history /proc/x/h.csv)
add_test(NAME "hostile: #15 compare --json under a missing folder is refused before any solve"
  COMMAND ${EXPECT} 2
  "--json /nonexistent/r.json: folder /nonexistent does not exist" ${PMG} compare --grid 4 --json /nonexistent/r.json)
add_test(NAME "hostile: #15 simulate -o naming an existing file is refused before any step"
  COMMAND sh -c
  "d=$(mktemp -d) && touch $d/f && ${EXPECT} 2 '-o .*/f: exists and is not a folder' $<TARGET_FILE:pmg> simulate -o $d/f; rc=$?; rm -rf $d; exit $rc")
# The per-step residual report: every accepted step has ||b - Av|| <= 2 tol ||b|| (the factor 2 is
# the solvers' allowance on the true residual), also at the turning points where b is small.
add_test(NAME "hostile: the per-step residual report stays within the step tolerance through a turning point"
  COMMAND sh -c
  "d=$(mktemp -d) && echo '{\"mesh\": {\"box\": [4, 1, 1], \"size\": [4, 1, 1]}, \"degree\": 2, \"initial\": {\"state\": \"deflected\", \"force\": [0, 0, -4000]}, \"time\": {\"dt\": 0.01, \"duration\": 1.5}}' > $d/s.json && $<TARGET_FILE:pmg> simulate $d/s.json -q --json $d/r.json > $d/out.txt && /usr/bin/python3 -c \"import json,sys; r=json.load(open('$d/r.json')); m=r['steps']['largest_residual_b']; print('largest', m); sys.exit(0 if 0 < m <= 2e-3 else 1)\"; rc=$?; rm -rf $d; exit $rc")
# SIGINT: the run stops after the step in progress, every written file complete, one line says where.
add_test(NAME "hostile: SIGINT stops pmg simulate -o with complete outputs and says where"
  COMMAND sh
  ${CMAKE_CURRENT_SOURCE_DIR}/sigint.sh $<TARGET_FILE:pmg>)
# Outputs change the named file only (issue #30): a device is written in place, never replaced by
# the temporary file's rename (as root that would turn /dev/null into a regular file).
add_test(NAME "hostile: --json /dev/null leaves /dev/null a device"
  COMMAND sh -c "${EXPECT} 0 'report: +/dev/null' $<TARGET_FILE:pmg> compare --grid 4 --solvers cg --json /dev/null && test -c /dev/null")
add_test(NAME "hostile: --history /dev/full is a write error, and /dev/full stays a device"
  COMMAND sh -c "${EXPECT} 1 '/dev/full: write failed .No space left on device.' $<TARGET_FILE:pmg> compare --grid 4 --solvers cg --history /dev/full; rc=$?; test -c /dev/full && exit $rc")
add_test(NAME "hostile: an output path that is a link keeps the link and writes its target"
  COMMAND sh -c "d=$(mktemp -d) && ln -s real.json $d/link.json && $<TARGET_FILE:pmg> compare --grid 4 --solvers cg --json $d/link.json > /dev/null && test -L $d/link.json && grep -q 'pmg compare' $d/real.json; rc=$?; rm -rf $d; exit $rc")
# Conflicts are errors, never resolved silently (issue #30).
add_test(NAME "hostile: --tol beside --set tol is refused"
  COMMAND ${EXPECT} 2 "--tol and --set tol=1e-2: give it once" ${PMG} compare --grid 4 --solvers cg --tol 1e-6 --set tol=1e-2)
add_test(NAME "hostile: --set with a key twice is refused"
  COMMAND ${EXPECT} 2 "--set: tol: given twice" ${PMG} compare --grid 4 --solvers cg --set tol=1e-3 --set tol=1e-4)
add_test(NAME "hostile: --fixed-iterations for a direct solver alone is refused"
  COMMAND ${EXPECT} 2 "--fixed-iterations: no solver of this run reads it" ${PMG} compare --grid 4 --solvers cholmod --fixed-iterations 5)
# Unbounded inputs are refused after a bounded read (issue #30): lines of at most 1 MiB,
# configuration files of at most 16 MiB, size estimates before meshing.
add_test(NAME "hostile: -m /dev/zero is refused after one long line"
  COMMAND ${EXPECT} 2 "/dev/zero:1: a line longer than 1048576 characters" ${PMG} compare -m /dev/zero --solvers cg)
add_test(NAME "hostile: -b /dev/zero is refused after one long line"
  COMMAND ${EXPECT} 2 "/dev/zero:1: a line longer than 1048576 characters" ${PMG} compare -m ${DATA}/spd.mtx -b /dev/zero --format csr --solvers cg)
add_test(NAME "hostile: a scene of /dev/urandom is refused after 16 MiB"
  COMMAND ${EXPECT} 2 "'/dev/urandom' is longer than 16777216 bytes" ${PMG} simulate /dev/urandom)
add_test(NAME "hostile: pmg mesh -n beyond this machine's memory is refused with its estimate"
  COMMAND ${EXPECT} 2 "-n 100000000 tetrahedra would need an estimated [0-9.]+ GB" ${PMG} mesh ${DATA}/cube.off -n 100000000)
add_test(NAME "hostile: SIGINT stops pmg mesh with exit 130 and removes its temporary folder"
  COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/mesh_sigint.sh $<TARGET_FILE:pmg> ${DATA}/cube.off)
# Silent wrong answers (issue #30): a direct solve is checked, so a numerically singular system
# (a Laplacian without boundary conditions, + 1e-14 I: every pivot positive) is a failure.
set(direct_methods cholmod)
if(PMG_HAVE_PETSC)
  list(APPEND direct_methods mumps)
endif()
foreach(m ${direct_methods})
  add_test(NAME "hostile: ${m} on a numerically singular system fails with exit 1"
    COMMAND ${EXPECT} 1 "${m}: the true relative residual .* is above the tolerance 1e-06 .*singular"
    ${PMG} compare -m ${DATA}/neumann_laplacian.mtx -b ${DATA}/neumann_laplacian_b.mtx --format csr --solvers ${m})
endforeach()
if(PMG_HAVE_PETSC)  # MUMPS starts MPI, whose allocations LeakSanitizer cannot attribute
  set_tests_properties("hostile: mumps on a numerically singular system fails with exit 1"
    PROPERTIES ENVIRONMENT "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1")
endif()
# Spurious failures and misleading errors (issue #30).
add_test(NAME "hostile: merged CG testing every 5000 iterations converges without a false breakdown"
  COMMAND ${EXPECT} 0 "mcg +converged" ${PMG} compare --grid 6 --solvers mcg --check-every 5000)
add_test(NAME "hostile: Gauss-Seidel with sweeps 0 is refused by its key"
  COMMAND ${EXPECT} 2 "smoother.sweeps.*\\[1, 1000\\]" ${PMG} compare --box 2 1 1 -p 2 --solvers pmg --set smoother.sweeps=0)
add_test(NAME "hostile: --dt 1e200 is refused naming --dt, not an operator"
  COMMAND ${EXPECT} 2 "--dt, --duration: dt 1e\\+200 s makes the step matrix M \\+ dt\\^2 K overflow" ${PMG} simulate --dt 1e200 --duration 1e201)
add_test(NAME "hostile: a command-line parse error has the pmg: error: prefix and exits 2"
  COMMAND ${EXPECT} 2 "^pmg: error: The following argument was not expected: --bogus \\(options: pmg compare --help\\)$" ${PMG} compare --bogus)
# The command-line sweep of 2026-12-03.
add_test(NAME "hostile: solver options nested 10,000 deep are refused, not a stack overflow"
  COMMAND ${EXPECT} 2 "nested deeper than 64 levels" ${PMG} simulate ${DATA}/deep_solver.json -q)
add_test(NAME "hostile: OMP_NUM_THREADS beyond 1024 is refused before a thread starts"
  COMMAND ${CMAKE_COMMAND} -E env OMP_NUM_THREADS=65536 ${EXPECT} 2 "OMP_NUM_THREADS='65536': expected a whole number of threads from 1 to 1024"
  ${PMG} compare -n 3 -s cg)
add_test(NAME "hostile: an OMP_NUM_THREADS that is not a number is refused"
  COMMAND ${CMAKE_COMMAND} -E env OMP_NUM_THREADS=abc ${EXPECT} 2 "OMP_NUM_THREADS='abc'" ${PMG} compare -n 3 -s cg)
add_test(NAME "hostile: --plot onto something that is not a regular file is refused"
  COMMAND ${EXPECT} 2 "--plot: /dev/null is not a regular file" ${PMG} compare -n 3 -s cg --plot /dev/null)
add_test(NAME "hostile: a load beyond double range fails its step instead of writing NaN"
  COMMAND ${EXPECT} 1 "simulation failed at step 1: the state is no longer finite"
  ${PMG} simulate ${DATA}/overflow_force.json -q -o ${CMAKE_CURRENT_BINARY_DIR}/overflow_force_out)
get_property(all_tests DIRECTORY PROPERTY TESTS)
list(FILTER all_tests INCLUDE REGEX "^hostile: ")
set_tests_properties(${all_tests} PROPERTIES LABELS "tools;hostile")

# Issue #48: a Matrix Market file whose last line lacks its line break is complete, not truncated.
add_test(NAME "hostile: #48 a Matrix Market file without a final newline is read"
  COMMAND ${EXPECT} 0 "cg  *converged" ${PMG} compare --matrix ${CORPUS}/matrix_market/no-final-newline.mtx
          --format csr --solvers cg)
