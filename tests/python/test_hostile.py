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


def test_index_arrays_of_a_live_matrix_are_read_only_and_copies_are_independent(quadratic):
    C = pmgkit.Csr(sp.eye(30, format="csr"))
    with pytest.raises(ValueError, match="read-only"):
        C.to_scipy().indices[:] = 2**30
    C.to_scipy().data[:] = 2.0  # values may change in place
    assert np.array_equal(C.matvec(np.ones(30)), 2 * np.ones(30))
    # copies (levels, model matrices) own every array: changing them changes nothing in pmgkit
    h, L, _ = quadratic
    b = np.ones(L[1].shape[0])
    x_before, _ = h.solver({"method": "mgpcg", "operator": "assembled", "tol": 1e-10}).solve(b)
    A = h.levels()[1]
    assert not np.shares_memory(A.indices, h.levels()[1].indices)
    A.indices[:] = 10**8
    P = h.prolongations()[0]
    P.indices[:] = 10**8
    m = pmgkit.ElasticModel(pmgkit.Mesh.box(2, 1, 1), 2)
    K = m.stiffness()
    K.data[1] = 0
    K.eliminate_zeros()
    assert m.stiffness().nnz > K.nnz
    x_after, _ = h.solver({"method": "mgpcg", "operator": "assembled", "tol": 1e-10}).solve(b)
    assert np.array_equal(x_before, x_after)


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
    # Two nodes of three components (3x3 blocks, as the block smoothers read), SPD.
    B = np.array([[2.0, 0.3, 0.1], [0.3, 2.0, 0.2], [0.1, 0.2, 2.0]])
    A = sp.kron(np.array([[2.5, -1.0], [-1.0, 2.5]]), B, format="csr")
    b = np.ones(6)
    before, _ = pmgkit.make_solver(A, {"method": method}).solve(b)
    s = pmgkit.make_solver(A, {"method": method})
    with pytest.raises(pmgkit.InputError):
        s.update(-A)  # negative definite: the smoother's set-up refuses it
    after, _ = s.solve(b)
    assert np.array_equal(before, after)


def test_levels_refused_by_the_solver_refuse_to_solve_until_an_update_succeeds(quadratic):
    _, L, P = quadratic
    b = np.ones(L[1].shape[0])
    s = pmgkit.multigrid(levels=L, prolongations=P, config={"tol": 1e-10})
    with pytest.raises(pmgkit.InputError):
        s.update([-L[0], -L[1]])  # symmetric, on the pattern: taken by the levels, refused by the set-up
    with pytest.raises(pmgkit.InputError, match="the last update failed"):
        s.solve(b)
    s.update(L)
    x, info = s.solve(b)
    assert info["status"] == "converged" and np.linalg.norm(L[1] @ x - b) <= 1e-9 * np.linalg.norm(b)


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
        with pytest.raises(pmgkit.InputError, match="b: entry 0 is NaN or Inf"):
            s.solve(b)
        with pytest.raises(pmgkit.InputError, match="x0: entry 0 is NaN or Inf"):
            s.solve(np.ones(A.shape[0]), x0=b)
        with pytest.raises(pmgkit.InputError, match="entry 0 .*identity row.* NaN or Inf"):
            s.aspreconditioner().matvec(b)


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
    with pytest.raises(pmgkit.InputError, match="too large"):
        pmgkit.Mesh.box(1, 1, 1, 1e200, 1e200, 1e200)


def test_messages_quoting_bytes_that_are_not_utf8_keep_their_text(tmp_path):
    path = tmp_path / "m.msh"
    path.write_bytes(b"_\x82\n")
    with pytest.raises(pmgkit.InputError, match=r"expected a \$Section, found '_\\x82'"):
        pmgkit.Mesh.read(str(path))


def test_predicates_answer_by_truth_value_and_none_or_strings_are_refused():
    mesh = pmgkit.Mesh.box(2, 1, 1)
    m = pmgkit.ElasticModel(mesh, 1)
    for answer in (None, "yes", np.array([True, False])):
        with pytest.raises(pmgkit.InputError, match="clamp: the function must return True or False"):
            m.fix_vertices(lambda x, a=answer: a)
    for answer in (lambda x: np.bool_(x[0] < 1e-9), lambda x: int(x[0] < 1e-9), lambda x: np.array([x[0] < 1e-9])):
        m = pmgkit.ElasticModel(mesh, 1)
        m.fix_vertices(answer)
        assert m.num_fixed == 5  # the x = 0 face's 4 corners and its centre
    with pytest.raises(pmgkit.InputError, match="on_face: the function must return True or False"):
        m.traction(lambda x: "x", [0, 0, 1])
    # a message that quotes text cut inside a UTF-8 character keeps its text (decoded with \xNN)
    with pytest.raises(pmgkit.InputError, match="clamp: the function must return True or False, it returned str"):
        m.fix_vertices(lambda x: "\u00e9" * 40)


def test_tets_must_be_integers_and_indices_in_machine_order(quadratic):
    box = pmgkit.Mesh.box(2, 1, 1)
    with pytest.raises(pmgkit.InputError, match="integer array, got float64"):
        pmgkit.Mesh(box.vertices, box.tets + 0.7)
    assert pmgkit.Mesh(box.vertices, box.tets.tolist()).num_tets == box.num_tets  # lists are arrays
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
