"""The solver contract under careless use (issue #30) from Python: a failure is an exception naming
its cause, never a normal return; inputs without end and sizes beyond the machine are refused
before they are read or allocated."""
import numpy as np
import pytest
import scipy.sparse as sp

import pmgkit


def _neumann_laplacian(n, shift):
    """7-point Laplacian on an n^3 grid without boundary conditions, + shift * I."""
    one = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tolil()
    one[0, 0] = one[n - 1, n - 1] = 1
    eye = sp.eye(n)
    A = sp.kron(sp.kron(one, eye), eye) + sp.kron(sp.kron(eye, one), eye) + sp.kron(sp.kron(eye, eye), one)
    return (A + shift * sp.eye(n ** 3)).tocsr()


@pytest.mark.parametrize("method", ["cholmod", "mumps"])
def test_a_direct_solve_of_a_singular_system_raises(method):
    if method not in {m["name"] for m in pmgkit.methods()}:
        pytest.skip(method + " is not in this build")
    A = _neumann_laplacian(9, 1e-14)
    b = np.sin(np.arange(A.shape[0]) * 0.37) + 0.5
    try:
        s = pmgkit.make_solver(A, {"method": method}, format="csr")
    except pmgkit.Error as e:  # a factorisation may already see it (a non-positive pivot)
        assert "positive definite" in str(e)
        return
    with pytest.raises(pmgkit.SolveError, match="singular"):
        s.solve(b)
    # Asked not to throw, the status and the true residual say it.
    x, info = pmgkit.make_solver(A, {"method": method, "throw_on_failure": False}, format="csr").solve(b)
    assert info["status"] == "stagnated"
    assert info["residual"] > 1e-6
    assert "singular" in info["message"]


def test_simulate_raises_on_a_failed_step_and_keeps_the_steps_before():
    scene = {"mesh": {"box": [2, 1, 1]}, "degree": 2, "time": {"dt": 0.01, "duration": 0.03},
             "initial": {"state": "deflected"},
             "solver": {"method": "pmg", "tol": 1e-12, "max_iterations": 1}}
    with pytest.raises(pmgkit.SolveError, match="simulation failed at step 1") as e:
        pmgkit.simulate(scene)
    assert e.value.summary["failed_step"] == 1
    assert e.value.summary["steps_done"] == 0


def test_simulate_refuses_a_scene_file_without_end():
    with pytest.raises(pmgkit.InputError, match="longer than"):
        pmgkit.simulate("/dev/zero")


def test_a_box_mesh_beyond_the_machine_is_refused_before_allocation():
    with pytest.raises(pmgkit.InputError, match="box mesh: 5000 x 5000 x 1 boxes.*would need an estimated"):
        pmgkit.Mesh.box(5000, 5000, 1)
    with pytest.raises(pmgkit.InputError, match="32-bit index"):
        pmgkit.Mesh.box(100000, 10000, 10)


def test_a_model_without_free_nodes_is_named():
    mesh = pmgkit.Mesh.box(2, 1, 1)
    m = pmgkit.ElasticModel(mesh, 2, pmgkit.Material(1e5, 0.3, 1e3))
    m.fix_vertices(lambda x: True)
    with pytest.raises(pmgkit.InputError, match="every node is fixed"):
        m.solve_static(m.gravity([0, 0, -9.81]))


def test_a_block_method_on_a_size_not_divisible_by_3_names_the_size():
    A = _neumann_laplacian(4, 1.0)  # 64 unknowns
    with pytest.raises(pmgkit.InputError, match="64 is not divisible by 3"):
        pmgkit.make_solver(A, {"method": "block-jacobi-pcg"})


def test_a_non_finite_number_in_a_config_dict_is_named():
    A = _neumann_laplacian(3, 1.0)
    with pytest.raises(pmgkit.InputError, match="config: preconditioner.omega: expected a finite number"):
        pmgkit.make_solver(A, {"method": "cg", "preconditioner": {"method": "jacobi", "omega": float("nan")}})
    with pytest.raises(pmgkit.InputError, match="config: tol: expected a finite number"):
        pmgkit.make_solver(A, {"method": "cg", "tol": float("inf")})


def test_a_0x0_system_is_named():
    with pytest.raises(pmgkit.InputError, match="0x0: there is nothing to solve"):
        pmgkit.make_solver(sp.csr_matrix((0, 0)), {"method": "cg"})


def test_a_refused_update_leaves_the_solver_on_its_matrix():
    A = _neumann_laplacian(4, 1.0)
    b = np.arange(A.shape[0], dtype=float)
    s = pmgkit.make_solver(A, {"method": "cholmod"}, format="csr")
    x_before, _ = s.solve(b)
    bad = A.copy().tolil()
    bad[0, 1] = 5.0  # no longer symmetric, same pattern
    with pytest.raises(pmgkit.InputError, match="not symmetric"):
        s.update(bad.tocsr())
    x_after, info = s.solve(b)
    assert info["status"] == "converged"
    assert np.allclose(x_after, x_before, rtol=1e-12, atol=0)
    assert np.linalg.norm(b - A @ x_after) <= 1e-10 * np.linalg.norm(b)
