"""Hostile input to the Python API: each case once crashed the interpreter, returned a wrong result
without an exception, or lost its message. Each must now raise an exception that names the problem,
or give the right result, and leave the objects as they were."""
import threading

import numpy as np
import pytest
import scipy.sparse as sp

import pmgkit


@pytest.fixture(scope="module")
def quadratic():
    """A clamped quadratic box: its two levels (CSR) and prolongation."""
    h = pmgkit.DegreeHierarchy(pmgkit.Mesh.box(2, 1, 1), 2, pmgkit.Material(), lambda p: p[0] < 1e-9)
    return h, [M.tocsr() for M in h.levels()], h.prolongations()


def test_row_pointers_that_rise_then_fall_are_refused_before_reading():
    # indptr [0, 2e9, 2] passes "first 0, last nnz": reading row 0 would run 2e9 entries long
    A = sp.csr_matrix((3, 3))
    A.indptr = np.array([0, 2_000_000_000, 2], dtype=np.int32)
    A.indices, A.data, A._shape = np.zeros(2, np.int32), np.ones(2), (2, 2**31 - 1)
    with pytest.raises(pmgkit.InputError, match="row pointers decrease at row 1"):
        pmgkit.multigrid(levels=[A], prolongations=[])


def test_views_of_a_live_matrix_are_read_only():
    C = pmgkit.Csr(sp.eye(30, format="csr"))
    for arr in C.to_scipy().indices, C.to_scipy().data:
        with pytest.raises(ValueError, match="read-only"):
            arr[:] = 2**30
    assert np.array_equal(C.matvec(np.ones(30)), np.ones(30))


def test_matvec_into_its_own_input_and_refused_outputs(quadratic):
    _, L, _ = quadratic
    A = L[1]
    expect = A @ np.arange(A.shape[0], dtype=float)
    for M in (pmgkit.Csr(A), pmgkit.Bcsr(A), pmgkit.Bcsr(A).to_bin_bcsr()):
        x = np.arange(A.shape[0], dtype=float)
        y = M.matvec(x, out=x)
        assert y is x or np.shares_memory(y, x)
        assert np.linalg.norm(x - expect) <= 1e-13 * np.linalg.norm(expect)
        for out in (np.zeros(A.shape[0], np.float32), np.zeros(A.shape[0], np.int64),
                    np.zeros(A.shape[0], ">f8"), np.zeros(A.shape[0] + 1)):
            with pytest.raises(pmgkit.InputError, match="out"):
                M.matvec(np.ones(A.shape[0]), out=out)
    with pytest.raises(pmgkit.InputError, match=r"shape \(%d, 1\)" % A.shape[0]):
        pmgkit.Csr(A).matvec(np.ones((A.shape[0], 1)))


def test_a_refused_level_update_leaves_the_levels_as_they_were(quadratic):
    _, L, P = quadratic
    b = np.ones(L[1].shape[0])
    s = pmgkit.multigrid(levels=L, prolongations=P, config={"tol": 1e-10})
    C = L[1].copy()
    C.data[5] += 1e5  # not symmetric: refused after part of the values were written
    with pytest.raises(pmgkit.InputError, match="not symmetric"):
        s.update([L[0], C])
    x, info = s.solve(b)
    assert info["status"] == "converged"
    assert np.linalg.norm(L[1] @ x - b) <= 1e-9 * np.linalg.norm(b)


@pytest.mark.parametrize("method", ["chebyshev", "gauss-seidel", "richardson", "jacobi"])
def test_a_refused_matrix_update_leaves_the_solver_as_it_was(method):
    A = sp.diags([-1.0, 2.5, -1.0], [-1, 0, 1], shape=(6, 6), format="csr")
    b = np.ones(6)
    before, _ = pmgkit.make_solver(A, {"method": method}).solve(b)
    s = pmgkit.make_solver(A, {"method": method})
    with pytest.raises(pmgkit.InputError):
        s.update(-A)  # negative definite: the smoother's set-up refuses it
    after, _ = s.solve(b)
    assert np.array_equal(before, after)


def test_nan_at_a_removed_identity_row_is_refused(quadratic):
    _, L, P = quadratic
    A = L[1].tolil()
    A[0:3, :] = 0
    A[:, 0:3] = 0
    A[0, 0] = A[1, 1] = A[2, 2] = 2.0
    s = pmgkit.multigrid(levels=[L[0], A.tocsr()], prolongations=P)
    for bad in (np.nan, np.inf):
        b = np.ones(A.shape[0])
        b[0] = bad
        with pytest.raises(pmgkit.InputError, match="entry 0 .*identity row.* NaN or Inf"):
            s.solve(b)


def test_level_indices_out_of_range_name_the_level(quadratic):
    h, L, P = quadratic
    s = pmgkit.multigrid(levels=L, prolongations=P)
    with pytest.raises(pmgkit.InputError, match="no level -1"):
        s.level_matrix(-1)
    with pytest.raises(pmgkit.InputError, match="no prolongation into level 0"):
        s.level_prolongation(0)
    with pytest.raises(pmgkit.InputError, match="no prolongation into level 2"):
        h.prolongation(2)


def test_box_meshes_refuse_infinite_and_vanishing_sides():
    with pytest.raises(pmgkit.InputError, match="positive and finite"):
        pmgkit.Mesh.box(1, 1, 1, float("inf"))
    with pytest.raises(pmgkit.InputError, match="too small"):
        pmgkit.Mesh.box(1, 1, 1, 1e-320)


def test_messages_quoting_bytes_that_are_not_utf8_keep_their_text(tmp_path):
    path = tmp_path / "m.msh"
    path.write_bytes(b"_\x82\n")
    with pytest.raises(pmgkit.InputError, match=r"expected a \$Section, found '_\\x82'"):
        pmgkit.Mesh.read(str(path))


def test_predicates_must_answer_true_or_false():
    mesh = pmgkit.Mesh.box(2, 1, 1)
    m = pmgkit.ElasticModel(mesh, 1)
    for answer in (None, "yes", np.array([True, False])):
        with pytest.raises(pmgkit.InputError, match="clamp: the function must return True or False"):
            m.fix_vertices(lambda x, a=answer: a)
    m.fix_vertices(lambda x: np.bool_(x[0] < 1e-9))  # NumPy's bool is an answer
    assert m.num_fixed > 0
    with pytest.raises(pmgkit.InputError, match="on_face: the function must return True or False"):
        m.traction(lambda x: "x", [0, 0, 1])


def test_tets_must_be_integers_and_indices_in_machine_order(quadratic):
    box = pmgkit.Mesh.box(2, 1, 1)
    with pytest.raises(pmgkit.InputError, match="integer array, got float64"):
        pmgkit.Mesh(box.vertices, box.tets + 0.7)
    swapped = quadratic[1][0].copy()
    swapped.indices = swapped.indices.astype(">i4")  # the same numbers, bytes swapped in memory
    with pytest.raises(pmgkit.InputError, match="byte order"):
        pmgkit.multigrid(levels=[swapped], prolongations=[])


def test_a_vector_that_read_petsc_would_refuse_is_not_written(tmp_path):
    with pytest.raises(pmgkit.InputError, match="entry 1 is NaN or Inf"):
        pmgkit.write_petsc(str(tmp_path / "v.bin"), np.array([1.0, np.nan]))
    assert not (tmp_path / "v.bin").exists()


def test_hierarchy_matrices_copied_while_solvers_are_built_on_other_threads():
    h = pmgkit.DegreeHierarchy(pmgkit.Mesh.box(2, 1, 1), 3, pmgkit.Material(), lambda p: p[0] < 1e-9)
    n = h.free_positions().size
    ref = h.matrix(2)[2].copy()
    bad = []
    cfg = {"method": "mgpcg", "smoother": {"method": "chebyshev", "preconditioner": {"method": "patch"}}}

    def build():
        for _ in range(4):
            h.solver(cfg).solve(np.ones(n))

    def read():
        for _ in range(100):
            if not np.array_equal(h.matrix(2)[2], ref):
                bad.append(1)

    threads = [threading.Thread(target=build), threading.Thread(target=build), threading.Thread(target=read)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not bad
