"""The BB elasticity FEM from NumPy: meshes, models, matrices, loads, point evaluation, static solves
and simulations, against the C++ tools' results."""
import csv
import json

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import pmgkit
from conftest import run_pmg


def test_mesh_from_arrays_and_its_checks():
    box = pmgkit.Mesh.box(2, 1, 1, 2.0, 1.0, 1.0)
    m = pmgkit.Mesh(box.vertices, box.tets)
    assert np.array_equal(m.vertices, box.vertices) and np.array_equal(m.tets, box.tets)
    inverted = box.tets.copy()
    inverted[0, [0, 1]] = inverted[0, [1, 0]]
    with pytest.raises(pmgkit.InputError, match="invert|orientation|negative"):
        pmgkit.Mesh(box.vertices, inverted)
    fixed = pmgkit.Mesh(box.vertices, inverted, fix_orientation=True)
    assert fixed.num_tets == box.num_tets
    with pytest.raises(pmgkit.InputError, match="vertex"):
        pmgkit.Mesh(box.vertices, box.tets + 1000)
    with pytest.raises(pmgkit.InputError):
        pmgkit.Material(young=-1.0)
    with pytest.raises(pmgkit.InputError, match="degree"):
        pmgkit.ElasticModel(box, 4)


def test_mesh_reordered_for_locality_is_the_same_mesh():
    box = pmgkit.Mesh.box(4, 2, 2, 2.0, 1.0, 1.0)
    rng = np.random.default_rng(5)
    shuffled = pmgkit.Mesh(box.vertices, box.tets[rng.permutation(box.num_tets)])
    r = shuffled.reordered_for_locality()
    assert (r.num_vertices, r.num_tets) == (box.num_vertices, box.num_tets)
    corners = lambda m: sorted(tuple(map(tuple, m.vertices[t])) for t in m.tets)  # each element's corners
    assert corners(r) == corners(shuffled)
    # vertices numbered in the order the elements first meet them
    first = [v for t in r.tets for v in t]
    assert list(dict.fromkeys(first)) == list(range(r.num_vertices))
    # the same stiffness, up to the numbering: equal eigenvalues of the clamped matrices
    def spectrum(m):
        model = pmgkit.ElasticModel(m, 1, pmgkit.Material(1e5, 0.3, 1e3))
        model.fix_vertices(lambda x: x[0] < 1e-9)
        return np.linalg.eigvalsh(model.stiffness().toarray())
    assert np.allclose(spectrum(r), spectrum(shuffled), rtol=1e-10, atol=0)


def test_model_matrices_match_the_hierarchy(cubic_box):
    mesh, h = cubic_box
    m = pmgkit.ElasticModel(mesh, 3, pmgkit.Material(1e5, 0.3, 1e3))
    m.fix_vertices(lambda x: x[0] < 1e-9)
    K = m.stiffness()
    assert abs(K - h.levels()[-1]).max() <= 1e-12 * abs(K).max()
    assert abs(K - K.T).max() <= 1e-12 * abs(K).max()
    M = m.mass()
    assert M.shape == K.shape and abs(M - M.T).max() == 0
    g = m.gravity([0, 0, -9.81])
    assert g.shape == (m.num_dofs,)
    assert g[2::3].sum() == pytest.approx(-9.81 * 1e3 * 2.0, rel=1e-12)  # rho g V
    # levels and prolongations out of range: an exception naming them, never a crash
    with pytest.raises(pmgkit.InputError, match="no prolongation into level 0"):
        h.prolongation(0)
    with pytest.raises(pmgkit.InputError, match="no prolongation into level 3"):
        h.prolongation(h.num_levels)
    with pytest.raises(pmgkit.InputError, match="no level -1"):
        h.matrix(-1)


def test_static_cantilever_against_the_multigrid_and_point_evaluation(cubic_box):
    mesh, h = cubic_box
    m = pmgkit.ElasticModel(mesh, 3, pmgkit.Material(1e5, 0.3, 1e3))
    m.fix_vertices(lambda x: x[0] < 1e-9)
    f = m.gravity([0, 0, -9.81])
    u, its = m.solve_static(f)
    assert its == 1
    # the same system through the multigrid on the hierarchy's levels
    x, info = pmgkit.multigrid(levels=h.levels(), prolongations=h.prolongations(),
                               config={"tol": 1e-12}).solve(h.restrict_to_free(f))
    assert np.linalg.norm(h.expand(x) - u) / np.linalg.norm(u) < 1e-9
    # point values: at the mesh vertices the BB field equals the vertex coefficients
    X = m.node_positions()
    verts = mesh.vertices
    d = m.displacement_at(u, verts)
    idx = [int(np.argmin(np.linalg.norm(X - v, axis=1))) for v in verts]
    assert np.allclose(d, u.reshape(-1, 3)[idx], rtol=0, atol=1e-14 * np.abs(u).max())
    tip = m.displacement_at(u, [[2.0, 0.5, 0.5]])
    assert tip[0, 2] < 0
    with pytest.raises(pmgkit.InputError, match="outside the mesh"):
        m.displacement_at(u, [[5.0, 0.5, 0.5]])


def test_point_evaluation_scales(cubic_box):
    """Located through a grid, not a scan: many points cost little more than a few."""
    mesh, _ = cubic_box
    m = pmgkit.ElasticModel(mesh, 2)
    u = np.random.default_rng(0).standard_normal(m.num_dofs)
    pts = np.random.default_rng(1).uniform([0, 0, 0], [2, 1, 1], size=(2000, 3))
    d = m.displacement_at(u, pts)
    assert d.shape == (2000, 3) and np.isfinite(d).all()


def test_simulate_matches_pmg_simulate(pmg_bin, tmp_path):
    scene = {
        "degree": 2, "mesh": {"box": [4, 1, 1], "size": [4.0, 1.0, 1.0]},
        "material": {"young": 5e5, "poisson": 0.3, "density": 1000.0, "model": "corotational"},
        "clamp": {"axis": "x", "fraction": 0.0},
        "initial": {"state": "deflected", "force": [0, 0, -400.0]},
        "time": {"dt": 0.01, "duration": 0.05},
        "solver": {"method": "pmg", "tol": 1e-8},
        "output": {"energy": True, "frame_every": 0},
    }
    r = pmgkit.simulate(scene)
    rec = r["records"]
    assert r["steps_done"] == 5 and rec["time"].shape == (6,) and rec["probe"].shape == (6, 3)
    assert r["failed_step"] == 0
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    run_pmg(pmg_bin, "simulate", path, "-o", tmp_path / "out", "-q")
    with open(tmp_path / "out" / "steps.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 6
    for k, row in enumerate(rows):
        assert float(row["probe_uz"]) == pytest.approx(rec["probe"][k, 2], rel=1e-9, abs=1e-15)
        assert int(row["iterations"]) == rec["iterations"][k]
        assert float(row["elastic"]) == pytest.approx(rec["elastic"][k], rel=1e-9)
    with pytest.raises(pmgkit.InputError):
        pmgkit.simulate({"degree": 7})


def test_a_hierarchy_builds_any_factory_solver_on_its_levels(cubic_box):
    _, h = cubic_box
    K = h.levels()[-1]
    b = h.restrict_to_free(h.gravity([0.0, 0.0, -9.81]))
    exact = spla.spsolve(K.tocsc(), b)
    for config in ({"method": "mgpcg", "tol": 1e-10}, {"method": "mgpcg", "operator": "matrix-free", "tol": 1e-10},
                   {"method": "pmg", "tol": 1e-10}, {"method": "cholmod"}, {"method": "petsc-mgpcg", "tol": 1e-10}):
        s = h.solver(config)
        assert s.shape == (len(b), len(b))
        x, info = s.solve(b)
        assert info["status"] == "converged", (config, info)
        assert np.linalg.norm(x - exact) <= 1e-8 * np.linalg.norm(exact), config
    mg = h.solver()  # mgpcg by default
    assert "multigrid" in mg.name
    x6, info6 = mg.solve(b, tol=1e-6)  # a new tolerance rebuilds the solver on the hierarchy
    assert info6["status"] == "converged" and info6["residual"] <= 2e-6
    with pytest.raises(pmgkit.InputError, match="DegreeHierarchy"):
        mg.update(K)
    with pytest.raises(pmgkit.InputError, match="mpi4py communicator"):
        h.solver({"method": "petsc-mgpcg"}, comm=7)
    with pytest.raises(pmgkit.InputError, match="no_such_key"):
        h.solver({"method": "mgpcg", "no_such_key": 1})


def test_symmetry_planes_in_a_degree_hierarchy():
    """components=(n_vertices, 3) booleans: a quarter bar with u_y held on y = 1/2 and u_z on
    z = 1/2 solves (matrix-free MGPCG) as SciPy's direct solve of its assembled matrix, with the
    held components exactly zero and the same iterations as the quarter clamped alone, +20%."""
    mesh = pmgkit.Mesh.box(4, 2, 2, 2.0, 0.5, 0.5)
    X = mesh.vertices
    held = np.zeros((len(X), 3), dtype=bool)
    held[:, 1] = np.abs(X[:, 1] - 0.5) < 1e-9
    held[:, 2] = np.abs(X[:, 2] - 0.5) < 1e-9
    material = pmgkit.Material(1e5, 0.3, 1e3)
    clamp = lambda x: x[0] < 1e-9  # noqa: E731
    h = pmgkit.DegreeHierarchy(mesh, 3, material, clamp=clamp, components=held)
    plain = pmgkit.DegreeHierarchy(mesh, 3, material, clamp=clamp)
    mask = h.constrained_dofs()
    assert mask.sum() > 0 and len(plain.constrained_dofs()) == 0
    b = h.restrict_to_free(h.gravity([9.81, -9.81, -9.81]))
    assert np.all(b[mask] == 0.0)
    x_ref = spla.spsolve(h.levels()[-1].tocsc(), b)
    x, info = h.solver({"method": "mgpcg", "tol": 1e-10}).solve(b)
    assert np.linalg.norm(x - x_ref) <= 1e-8 * np.linalg.norm(x_ref)
    assert np.all(x[mask] == 0.0)
    _, info_plain = plain.solver({"method": "mgpcg", "tol": 1e-10}).solve(plain.restrict_to_free(plain.gravity([9.81, -9.81, -9.81])))
    assert info["iterations"] <= 1.2 * info_plain["iterations"]
    with pytest.raises(pmgkit.InputError, match="n_vertices, 3"):
        pmgkit.DegreeHierarchy(mesh, 2, material, clamp=clamp, components=held[:, :2])
    scene = {"mesh": {"box": [4, 1, 1], "size": [2, 0.5, 0.5]}, "degree": 2, "clamp": {"axis": "x"},
             "symmetry": [{"axis": "y", "at": "max"}, {"axis": "z", "at": "max"}],
             "loads": {"gravity": [9.81, 0, 0]}, "time": {"dt": 0.01, "duration": 0.03},
             "solver": {"method": "mgpcg", "tol": 1e-8}, "output": {"probe": [2.0, 0.5, 0.5]}}
    r = pmgkit.simulate(scene)
    assert r["steps_done"] == 3
    assert np.all(r["records"]["probe"][:, 1:] == 0.0)


def test_a_refined_hierarchy_keeps_its_coarser_meshes_under_the_linear_level():
    mesh = pmgkit.Mesh.box(2, 1, 1, 1.0, 0.5, 0.5)
    material = pmgkit.Material(500e3, 0.3, 1000.0)
    h = pmgkit.DegreeHierarchy(mesh, 2, material, clamp=lambda X: X[0] < 1e-12, refine=1)
    assert h.mesh.num_tets == 8 * mesh.num_tets
    b = h.restrict_to_free(h.gravity([0.0, 0.0, -9.81]))
    exact = spla.spsolve(h.levels()[-1].tocsc(), b)
    on = h.solver({"method": "mgpcg", "coarse_meshes": "on", "tol": 1e-10})
    assert "mesh coarser by 1" in on.describe()
    x, info = on.solve(b)
    assert info["status"] == "converged"
    assert np.linalg.norm(x - exact) <= 1e-8 * np.linalg.norm(exact)
    # A clamp given for the coarse mesh's vertices clamps the same vertices of the refined one.
    flags = mesh.vertices[:, 0] < 1e-12
    same = pmgkit.DegreeHierarchy(mesh, 2, material, clamp=flags, refine=1)
    assert np.array_equal(same.free_positions(), h.free_positions())
    # Without refinement there are no coarser meshes to put under the linear level.
    plain = pmgkit.DegreeHierarchy(mesh, 2, material, clamp=flags)
    with pytest.raises(pmgkit.InputError, match="coarse_meshes"):
        plain.solver({"method": "mgpcg", "coarse_meshes": "on"})
    with pytest.raises(pmgkit.InputError, match="refine"):
        pmgkit.DegreeHierarchy(mesh, 2, material, clamp=flags, refine=5)



def test_mixed_elasticity_solves_the_saddle_point_without_locking():
    mesh = pmgkit.Mesh.box(4, 1, 1, 2.0, 0.5, 0.5)
    clamp = lambda X: X[0] < 1e-12
    for nu in (0.3, 0.4999, 0.5):
        m = pmgkit.MixedElasticity(mesh, 2, pmgkit.Material(1e5, 0.3, 1e3), poisson=nu, clamp=clamp)
        f = m.gravity([0.0, 0.0, -9.81])
        u, p, info = m.solve(f, {"method": "mixed-minres", "tol": 1e-11})
        assert info["status"] == "converged"
        indptr, indices, data, shape = m.system()
        K = sp.csr_matrix((data, indices, indptr), shape=shape)
        b = m.rhs(f)
        # What MINRES promises: the true residual of the assembled system within 2 tol (the
        # system's pressure unknowns are s p, s = 1 for the static system).
        mine = np.concatenate([m.restrict_to_free(u), p])
        assert np.linalg.norm(b - K @ mine) <= 2e-11 * np.linalg.norm(b)
        assert p.shape == (m.num_pressure,) and u.shape == f.shape
    with pytest.raises(pmgkit.InputError, match="degree must be 2 or 3"):
        pmgkit.MixedElasticity(mesh, 1, clamp=clamp)
    with pytest.raises(pmgkit.InputError, match=r"\(0, 0.5\]"):
        pmgkit.MixedElasticity(mesh, 2, poisson=0.7, clamp=clamp)


def test_mixed_elasticity_corotational_fixed_point():
    mesh = pmgkit.Mesh.box(4, 1, 1, 2.0, 0.5, 0.5)
    m = pmgkit.MixedElasticity(mesh, 2, pmgkit.Material(1e5, 0.4999, 1e3), clamp=lambda X: X[0] < 1e-12)
    f = m.gravity([0.0, 0.0, -9.81])
    # Small loads: the rotations are O(load), so the corotational answer differs from the linear one
    # by O(load^2): a hundredth of the load, a hundredth of the relative difference. (At 1e-3 g
    # the tip already sags 2 cm: the bar is soft.)
    relative = []
    for scale in (1e-4, 1e-6):
        u_lin, _, _ = m.solve(scale * f, {"tol": 1e-13})
        u_rot, _, info = m.solve(scale * f, {"tol": 1e-13}, corotational=True)
        assert info["fixed_point_iterations"] >= 2
        relative.append(np.linalg.norm(u_rot - u_lin) / np.linalg.norm(u_lin))
    assert 0.005 * relative[0] <= relative[1] <= 0.02 * relative[0]
    _, _, big = m.solve(1e-2 * f, {"tol": 1e-10}, corotational=True)
    assert big["fixed_point_iterations"] > info["fixed_point_iterations"]
    with pytest.raises(pmgkit.InputError, match="corotational material needs mixed-gmres or mixed-minres"):
        m.solve(f, {"method": "mumps"}, corotational=True)
