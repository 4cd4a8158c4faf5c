"""pmgkit from Python across MPI ranks, with mpi4py (run under mpirun -np 2 or 3; ctest does).

- DegreeHierarchy.solver({"method": "petsc-mgpcg"}, comm) equals the serial MGPCG on the same
  hierarchy to 1e-8, every rank gets the same x, and the iteration counts agree with the one-rank
  communicator's (a split of the world) within one.
- pmgkit.simulate of a petsc-mgpcg scene steps across the ranks, and with distributed_mesh=True on
  a mesh no rank holds whole: its probe and energies equal the
  serial run's to 1e-8 over 10 corotational steps; rank 0 writes steps.csv, every rank its piece.
- pmgkit.solve_distributed builds a scene on the ranks (DMPlex, no rank holding the whole mesh):
  its compliance equals the serial MGPCG's to 1e-9, with a symmetry plane too; an inclusion and
  other methods are refused.
- What is not a communicator, and ranks given different output directories, are a clear
  InputError on every rank; so are ranks given different right-hand sides, guesses, materials,
  keys or time steps (the first difference named), PETSc options nobody reads and a freed
  communicator.
"""
import os
import sys
import tempfile

import numpy as np
from mpi4py import MPI

import pmgkit

comm = MPI.COMM_WORLD
rank, size = comm.Get_rank(), comm.Get_size()
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("rank %d: FAILED: %s" % (rank, what), flush=True)


# ---- a solve on a communicator ----
mesh = pmgkit.Mesh.box(6, 2, 2, 1.0, 0.3, 0.3)
h = pmgkit.DegreeHierarchy(mesh, 2, pmgkit.Material(500e3, 0.3, 1000.0), clamp=lambda X: X[0] < 1e-12)
b = h.restrict_to_free(h.gravity([0.0, 0.0, -9.81]))
x_serial, info_serial = h.solver({"method": "mgpcg", "tol": 1e-10, "lowest_level": "cholmod"}).solve(b)
across = h.solver({"method": "petsc-mgpcg", "tol": 1e-10}, comm=comm)
x, info = across.solve(b)
check(info["status"] == "converged", "petsc-mgpcg converged: %s" % info)
err = np.linalg.norm(x - x_serial) / np.linalg.norm(x_serial)
check(err <= 1e-8, "petsc-mgpcg equals the serial MGPCG: %.2e" % err)
check(info["residual"] <= 2e-10, "true residual %.2e" % info["residual"])
spread = max(np.abs(y - x).max() for y in comm.allgather(x))
check(spread == 0.0, "every rank holds the same x (spread %.2e)" % spread)
# A new tolerance rebuilds the solver on the same hierarchy (and communicator).
x6, info6 = across.solve(b, tol=1e-6)
check(info6["status"] == "converged" and info6["iterations"] < info["iterations"],
      "a new tol: %d iterations against %d" % (info6["iterations"], info["iterations"]))
# Each rank alone, on a communicator of one (a split of the world): the one-rank iterations.
alone = comm.Split(color=rank, key=0)
x1, info1 = h.solver({"method": "petsc-mgpcg", "tol": 1e-10}, comm=alone).solve(b)
check(abs(info1["iterations"] - info["iterations"]) <= 1,
      "iterations %d on %d ranks, %d on one" % (info["iterations"], size, info1["iterations"]))
check(np.linalg.norm(x1 - x_serial) <= 1e-8 * np.linalg.norm(x_serial), "the one-rank solution")
alone.Free()
if rank == 0:
    print("solve: %d ranks %d iterations, one rank %d, serial MGPCG %d; |x - x_serial|/|x_serial| = %.2e"
          % (size, info["iterations"], info1["iterations"], info_serial["iterations"], err), flush=True)

# ---- bad input: every rank raises, nobody hangs ----
for bad in (42, "world"):
    try:
        h.solver({"method": "petsc-mgpcg"}, comm=bad)
        check(False, "comm=%r refused" % (bad,))
    except pmgkit.InputError as e:
        check("mpi4py communicator" in str(e), "the message names the communicator: %s" % e)

# ---- a simulation across the ranks ----
scene = {"mesh": {"box": [6, 2, 2], "size": [1.0, 0.3, 0.3]}, "degree": 2,
         "material": {"model": "corotational", "young": 5e5, "poisson": 0.3, "density": 1000.0},
         "clamp": {"axis": "x", "fraction": 0.0}, "loads": {"gravity": [0.0, 0.0, -9.81]},
         "time": {"dt": 0.01, "duration": 0.1}, "output": {"energy": True, "frame_every": 5},
         "solver": {"method": "mgpcg", "tol": 1e-11, "lowest_level": "cholmod"}}
serial = pmgkit.simulate(scene)
scene["solver"] = {"method": "petsc-mgpcg", "tol": 1e-11}
out_dir = comm.bcast(tempfile.mkdtemp() if rank == 0 else None, root=0)
dist = pmgkit.simulate(scene, out_dir)
check(any("ranks: %d" % size in n for n in dist["notes"]), "the run says it stepped across ranks: %s" % dist["notes"])
for key in ("kinetic", "elastic", "total_energy"):
    a, c = serial["records"][key], dist["records"][key]
    rel = np.abs(a - c).max() / max(np.abs(a).max(), 1e-30)
    check(rel <= 1e-8, "%s equal to 1e-8: %.2e" % (key, rel))
pa, pc = serial["records"]["probe"], dist["records"]["probe"]
rel = np.abs(pa - pc).max() / max(np.abs(pa).max(), 1e-30)
check(rel <= 1e-8, "probe equal to 1e-8: %.2e" % rel)
comm.Barrier()
if rank == 0:
    files = sorted(os.listdir(out_dir))
    check("steps.csv" in files and "simulation.pvd" in files, "rank 0 wrote steps.csv and the .pvd: %s" % files)
    for step in (0, 5, 10):
        check(all("frame_%06d_%d.vtu" % (step, r) in files for r in range(size)) and "frame_%06d.pvtu" % step in files,
              "frame %d: one piece per rank and the .pvtu" % step)
    print("simulate: %d steps across %d ranks, probe and energies equal the serial run's (largest %.2e)"
          % (dist["steps_done"], size, rel), flush=True)

# The same scene on a mesh no rank holds whole: built on the ranks, the same probe and energies.
mesh_run = pmgkit.simulate(scene, distributed_mesh=True)
check(any("none holding it whole" in n for n in mesh_run["notes"]), "built on the ranks: %s" % mesh_run["notes"])
for key in ("kinetic", "elastic", "total_energy", "probe"):
    a, c = serial["records"][key], mesh_run["records"][key]
    rel = np.abs(a - c).max() / max(np.abs(a).max(), 1e-30)
    check(rel <= 1e-8, "distributed mesh: %s equal to 1e-8: %.2e" % (key, rel))

# Ranks given different output directories: refused on every rank, nobody hangs.
try:
    pmgkit.simulate(scene, out_dir if rank == 0 else "")
    check(size == 1, "different output directories refused")
except pmgkit.InputError as e:
    check("disagree on the output directory" in str(e), "the message says why: %s" % e)

# ---- ranks that disagree: the same named error on every rank, never a wrong answer or a hang ----
def refused(what, call, words):
    """call() must raise pmgkit.InputError naming `words` on every rank (size > 1)."""
    try:
        call()
        check(size == 1, "%s: accepted" % what)
    except pmgkit.InputError as e:
        check(words in str(e) and "disagree" in str(e), "%s: the message names it: %s" % (what, e))
    messages = comm.allgather(None)  # still in step: nobody hangs
    check(len(messages) == size, "%s: every rank returned" % what)


refused("a right-hand side per rank", lambda: across.solve(b * (1 + rank)), "the right-hand side")
refused("a starting guess per rank", lambda: across.solve(b, x0=np.full_like(b, rank)), "the starting guess")
other = pmgkit.DegreeHierarchy(mesh, 2, pmgkit.Material(500e3, 0.3 if rank == 0 else 0.2, 1000.0),
                               clamp=lambda X: X[0] < 1e-12)
refused("a material per rank", lambda: other.solver({"method": "petsc-mgpcg"}, comm=comm), "Poisson's ratio")
refused("keys per rank", lambda: h.solver({"method": "petsc-mgpcg", "smoothing_steps": 2 + rank}, comm=comm),
        "smoothing_steps")
step_scene = dict(scene, time={"dt": 0.01 * (1 + rank), "duration": 0.04})
refused("a time step per rank", lambda: pmgkit.simulate(step_scene), "dt")
# Property: random per-rank perturbations of the inputs (the same seed on every rank; one rank,
# chosen at random, perturbs one input). Every case ends in the same answer on every rank (no
# perturbation) or the same named InputError on every rank, and the ranks stay in step.
rng = np.random.default_rng(48)
for case in range(8):
    what = ["nothing", "b", "x0", "tol"][case % 4]
    victim = int(rng.integers(size)) if size > 1 else 0
    delta = float(rng.uniform(1e-12, 1e-3))
    bb = b * (1 + delta) if (what == "b" and rank == victim) else b
    x0 = np.full_like(b, delta) if (what == "x0" and rank == victim) else np.zeros_like(b)
    config = {"method": "petsc-mgpcg", "tol": 1e-10 * (1 + delta) if (what == "tol" and rank == victim) else 1e-10}
    try:
        got, outcome = h.solver(config, comm=comm).solve(bb, x0=x0)[0], "answer"
    except pmgkit.InputError as e:
        got, outcome = str(e), "error"
    outcomes = comm.allgather((outcome, got if outcome == "error" else None))
    check(len({o for o, _ in outcomes}) == 1, "case %d (%s on rank %d): every rank ends alike: %s"
          % (case, what, victim, [o for o, _ in outcomes]))
    if what == "nothing" or size == 1:
        check(outcome == "answer" and np.abs(got - x).max() <= 1e-8 * np.abs(x).max(),
              "case %d: unperturbed, the same answer" % case)
    else:
        check(outcome == "error" and len({m for _, m in outcomes}) == 1 and "disagree" in outcomes[0][1],
              "case %d (%s): the same named error on every rank: %s" % (case, what, outcomes[0][1]))

# The solver still works after the refusals (they end before any PETSc work).
x_again, info_again = across.solve(b)
check(info_again["status"] == "converged" and np.abs(x_again - x).max() <= 1e-8 * np.abs(x).max(),
      "the solver answers as before after refused calls")
# PETSc options nobody reads are refused, on every rank alike.
try:
    h.solver({"method": "petsc-mgpcg", "options": "-bogus_option 3"}, comm=comm)
    check(False, "an unused PETSc option accepted")
except pmgkit.InputError as e:
    check("-bogus_option" in str(e), "the unused option is named: %s" % e)
# A freed communicator: an InputError, not a crash.
mine = comm.Dup()
on_mine = h.solver({"method": "petsc-mgpcg", "tol": 1e-8}, comm=mine)
mine.Free()
try:
    on_mine.solve(b)
    check(False, "a freed communicator accepted")
except pmgkit.InputError as e:
    check("freed" in str(e), "the message says the communicator was freed: %s" % e)

# ---- a scene on a mesh no rank holds whole (pmgkit.solve_distributed) ----
box_scene = {"mesh": {"box": [4, 2, 2], "size": [1.0, 0.5, 0.5]}, "degree": 2,
             "material": {"young": 500e3, "poisson": 0.3, "density": 1000.0},
             "clamp": {"axis": "x", "fraction": 0.0}, "loads": {"gravity": [0.0, 0.0, -9.81]}}
r = pmgkit.solve_distributed(box_scene, comm, {"tol": 1e-11})
serial_row = pmgkit.study_scene(box_scene, ["mgpcg"], reference=None)[0]  # the whole scene, on this rank
check(r["status"] == "converged" and r["true_relative_residual"] < 1e-10, "solve_distributed converged: %s" % r["status"])
check(abs(r["compliance"] - serial_row["b_dot_x"]) <= 1e-9 * abs(serial_row["b_dot_x"]),
      "solve_distributed's compliance %r equals the serial MGPCG's %r" % (r["compliance"], serial_row["b_dot_x"]))
check(len(r["history"]) == r["iterations"] + 1 and r["history"][0] == 1.0, "the residual history has one entry per iteration")
owned = comm.allreduce(r["owned_displacement"].size, op=MPI.SUM)
check(owned == r["unknowns"], "the ranks' owned unknowns add up to %d (got %d)" % (r["unknowns"], owned))
check(comm.allgather(r["iterations"]) == [r["iterations"]] * size, "every rank reports the same solve")
# A symmetry plane: components held on their own, the serial MGPCG's compliance.
sym_scene = dict(box_scene, symmetry=[{"axis": "y", "at": "max"}])
r = pmgkit.solve_distributed(sym_scene, comm, {"tol": 1e-11})
serial_row = pmgkit.study_scene(sym_scene, ["mgpcg"], reference=None)[0]
check(abs(r["compliance"] - serial_row["b_dot_x"]) <= 1e-9 * abs(serial_row["b_dot_x"]),
      "with a symmetry plane solve_distributed's compliance %r equals the serial MGPCG's %r"
      % (r["compliance"], serial_row["b_dot_x"]))
try:
    pmgkit.solve_distributed(dict(box_scene, material=dict(box_scene.get("material", {}),
                                  inclusion={"min": [5, 5, 5], "max": [6, 6, 6], "young": 1e7})), comm)
    check(False, "solve_distributed accepted an inclusion holding no element")
except pmgkit.InputError as e:
    check("inclusion" in str(e), "solve_distributed refuses an empty inclusion by name: %s" % e)
try:
    pmgkit.solve_distributed(box_scene, comm, {"method": "mgpcg"})
    check(False, "solve_distributed accepted another method")
except pmgkit.InputError as e:
    check("petsc-mgpcg" in str(e), "solve_distributed names its one method: %s" % e)

all_failures = comm.allreduce(len(failures), op=MPI.SUM)
if rank == 0:
    print("mpi_ranks.py: %s" % ("ok" if all_failures == 0 else "%d failures" % all_failures), flush=True)
sys.exit(0 if all_failures == 0 else 1)
