"""Multigrid on the caller's levels: against the C++ tool on the same files, Galerkin levels, the
layouts, dof prolongations, Dirichlet identity rows, every option reaching the cycle, and errors."""
import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

import pmgkit
from conftest import run_pmg


def test_same_as_pmg_compare_on_the_same_files(pmg_bin, levels, rhs, tmp_path):
    """The CLI and the module build the same cycle: same iterations, same solution to round-off."""
    As, Ps = levels
    files = []
    for l, A in enumerate(As):
        scipy.io.mmwrite(tmp_path / f"A{l}.mtx", A.tocoo(), symmetry="symmetric", precision=17)
        files.append(tmp_path / f"A{l}.mtx")
    pfiles = []
    for l, P in enumerate(Ps, start=1):
        scipy.io.mmwrite(tmp_path / f"P{l}.mtx", P.tocoo(), precision=17)
        pfiles.append(tmp_path / f"P{l}.mtx")
    scipy.io.mmwrite(tmp_path / "b.mtx", rhs[:, None], precision=17)
    for method, extra in (("mgpcg", []), ("pmg", []), ("mgpcg", ["--galerkin-from-finest"])):
        mats = files[-1:] if extra else files
        out = run_pmg(pmg_bin, "compare", "--levels", ",".join(map(str, mats)), "--prolongations",
                      ",".join(map(str, pfiles)), "--rhs", tmp_path / "b.mtx", "--solvers", method,
                      "--tol", "1e-10", "--solution-out", tmp_path / "x.mtx", *extra)
        row = next(line for line in out.splitlines() if line.startswith(method + " "))
        cli_iterations = int(row.split()[2])
        x_cli = scipy.io.mmread(tmp_path / "x.mtx").ravel()
        if extra:
            s = pmgkit.multigrid(finest=As[-1], prolongations=Ps, config={"method": method, "tol": 1e-10})
        else:
            s = pmgkit.multigrid(levels=As, prolongations=Ps, config={"method": method, "tol": 1e-10})
        x, info = s.solve(rhs)
        assert info["iterations"] == cli_iterations, (method, extra)
        assert np.linalg.norm(x - x_cli) / np.linalg.norm(x_cli) < 1e-12, (method, extra)
        assert info["residual"] < 1e-10


def test_galerkin_levels_equal_explicit_galerkin_products(levels, rhs):
    As, Ps = levels
    # R A P from the finest down, formed by SciPy
    G = [None] * len(As)
    G[-1] = As[-1].tocsr()
    for l in range(len(As) - 1, 0, -1):
        P3 = sp.kron(Ps[l - 1], sp.identity(3), format="csr")
        G[l - 1] = (P3.T @ G[l] @ P3).tocsr()
    x1, i1 = pmgkit.multigrid(levels=G, prolongations=Ps, config={"tol": 1e-10}).solve(rhs)
    x2, i2 = pmgkit.multigrid(finest=As[-1], prolongations=Ps, config={"tol": 1e-10}).solve(rhs)
    assert i1["iterations"] == i2["iterations"]
    assert np.linalg.norm(x1 - x2) / np.linalg.norm(x1) < 1e-10
    with pytest.raises(pmgkit.InputError, match="galerkin"):
        pmgkit.multigrid(finest=As[-1], prolongations=Ps, config={"coarse_operator": "geometric"})


def component_major(n_nodes):
    """perm[i] = interleaved index of component-major index i."""
    i = np.arange(3 * n_nodes)
    return 3 * (i % n_nodes) + i // n_nodes


def test_component_major_layout_and_dof_prolongations(levels, rhs):
    As, Ps = levels
    x_ref, info_ref = pmgkit.multigrid(levels=As, prolongations=Ps, config={"tol": 1e-10}).solve(rhs)
    perms = [component_major(A.shape[0] // 3) for A in As]
    Ac = [A.tocsr()[p][:, p] for A, p in zip(As, perms)]
    Pd = [sp.kron(P, sp.identity(3), format="csr")[perms[l + 1]][:, perms[l]] for l, P in enumerate(Ps)]
    bc = rhs[perms[-1]]
    for prolongations in (Ps, Pd):  # node prolongations, or dof prolongations in the same layout
        s = pmgkit.multigrid(levels=Ac, prolongations=prolongations, config={"tol": 1e-10}, layout="component")
        x, info = s.solve(bc)
        assert info["iterations"] == info_ref["iterations"]
        assert np.linalg.norm(x - x_ref[perms[-1]]) / np.linalg.norm(x_ref) < 1e-12
    with pytest.raises(pmgkit.InputError, match="layout='component'"):
        pmgkit.multigrid(levels=Ac, prolongations=Ps)  # interleaved assumed: refused, not diverging
    with pytest.raises(pmgkit.InputError, match="layout"):
        pmgkit.multigrid(levels=As, prolongations=Ps, layout="rowwise")
    # a dof prolongation that mixes components is refused
    bad = sp.kron(Ps[-1], np.ones((3, 3)), format="csr")
    with pytest.raises(pmgkit.InputError, match="components"):
        pmgkit.multigrid(levels=As, prolongations=[Ps[0], bad])


def embed_with_identity_rows(A, free_nodes, n_nodes, diag=1.0):
    """A over the free nodes embedded in the full node set, clamped nodes as identity rows (what
    FEM codes produce after a symmetric Dirichlet elimination)."""
    dofs = (3 * np.repeat(free_nodes, 3) + np.tile(np.arange(3), len(free_nodes)))
    E = sp.csr_matrix((np.ones(len(dofs)), (dofs, np.arange(len(dofs)))), shape=(3 * n_nodes, A.shape[0]))
    fixed = np.setdiff1d(np.arange(3 * n_nodes), dofs)
    D = sp.csr_matrix((np.full(len(fixed), diag), (fixed, fixed)), shape=(3 * n_nodes, 3 * n_nodes))
    return (E @ A @ E.T + D).tocsr(), dofs, fixed


def test_dirichlet_identity_rows_are_removed(levels, rhs):
    As, Ps = levels
    x_ref, info_ref = pmgkit.multigrid(levels=As, prolongations=Ps, config={"tol": 1e-10}).solve(rhs)
    # every level gets 5 extra clamped nodes as identity rows; the prolongations get full rows
    # and columns for them (interpolating from and into them, as a FEM code's would)
    rng = np.random.default_rng(3)
    full, free_of, n_full = [], [], []
    for A in As:
        n = A.shape[0] // 3
        N = n + 5
        free = np.sort(rng.choice(N, n, replace=False))
        F, dofs, fixed = embed_with_identity_rows(A, free, N, diag=1e3)
        full.append(F)
        free_of.append(free)
        n_full.append(N)
    Pf = []
    for l, P in enumerate(Ps):
        Q = sp.lil_matrix((n_full[l + 1], n_full[l]))
        Q[np.ix_(free_of[l + 1], free_of[l])] = P.toarray()
        fixed_f = np.setdiff1d(np.arange(n_full[l + 1]), free_of[l + 1])
        Q[fixed_f, 0] = 0.5  # fine clamped nodes interpolating from a coarse node
        Pf.append(Q.tocsr())
    b = np.zeros(full[-1].shape[0])
    dofs = 3 * np.repeat(free_of[-1], 3) + np.tile(np.arange(3), len(free_of[-1]))
    b[dofs] = rhs
    fixed = np.setdiff1d(np.arange(len(b)), dofs)
    b[fixed] = 2e3  # prescribed value 2 on the identity rows (diagonal 1e3)
    s = pmgkit.multigrid(levels=full, prolongations=Pf, config={"tol": 1e-10})
    assert s.removed_nodes == [5] * len(As)
    x, info = s.solve(b)
    assert info["iterations"] == info_ref["iterations"]
    assert np.linalg.norm(x[dofs] - x_ref) / np.linalg.norm(x_ref) < 1e-12
    assert np.allclose(x[fixed], 2.0)
    assert info["residual"] < 1e-10
    # identity rows whose columns were kept (no symmetric elimination): refused with what to do
    kept_cols = full[-1].tolil()
    kept_cols[dofs[0], fixed[0]] = kept_cols[fixed[0], fixed[0]]
    with pytest.raises(pmgkit.InputError, match="columns of identity rows must be zero"):
        pmgkit.multigrid(levels=full[:-1] + [kept_cols.tocsr()], prolongations=Pf)


def test_symmetry_planes_through_the_multigrid(cubic_box, levels):
    """A quarter model: the clamped cantilever with u_y = 0 on y = 0 and u_z = 0 on z = 0 (identity
    rows on those components only): MGPCG equals SciPy's direct solve of the constrained system."""
    import scipy.sparse.linalg as spla
    _, h = cubic_box
    As, Ps = levels
    A = As[-1].tocsr()
    X = h.free_positions().reshape(-1, 3)
    fixed = np.zeros(A.shape[0], dtype=bool)
    fixed[3 * np.flatnonzero(np.abs(X[:, 1]) < 1e-9) + 1] = True
    fixed[3 * np.flatnonzero(np.abs(X[:, 2]) < 1e-9) + 2] = True
    free = sp.diags((~fixed).astype(float))
    Ac = (free @ A @ free + sp.diags(np.where(fixed, A.diagonal(), 0.0))).tocsr()
    Ac.eliminate_zeros()
    b = h.restrict_to_free(h.gravity([0.0, -9.81, -9.81]))
    b[fixed] = 0.0
    x_ref = spla.spsolve(Ac.tocsc(), b)
    for config in ({"tol": 1e-10}, {"tol": 1e-10, "smoother": "chebyshev"}):
        x, info = pmgkit.multigrid(finest=Ac, prolongations=Ps, config=config).solve(b)
        assert info["status"] == "converged"
        assert np.linalg.norm(x - x_ref) <= 1e-8 * np.linalg.norm(x_ref), config
        assert np.all(x[fixed] == 0.0)
        _, plain = pmgkit.multigrid(finest=A, prolongations=Ps, config=config).solve(b)
        print(config, "iterations:", info["iterations"], "constrained,", plain["iterations"], "clamped only")
        assert info["iterations"] <= 1.2 * plain["iterations"] + 1, config


def test_every_cycle_option_reaches_the_cycle(levels, rhs):
    As, Ps = levels
    seen = {}
    for name, cfg in {
        "gs": {"smoother": {"method": "gauss-seidel", "sweeps": 2}},
        "gs5": {"smoother": {"method": "gauss-seidel", "sweeps": 5}},
        "cheb": {"smoother": {"method": "chebyshev", "degree": 3}},
        "W": {"cycle": "W", "smoother": {"method": "gauss-seidel", "sweeps": 2}},
        "boomeramg": {"lowest_level": {"method": "boomeramg"}, "smoother": {"method": "gauss-seidel", "sweeps": 2}},
    }.items():
        x, info = pmgkit.multigrid(levels=As, prolongations=Ps, config={"method": "pmg", "tol": 1e-8, **cfg}).solve(rhs)
        assert info["residual"] < 1e-8
        seen[name] = (info["iterations"], x)
    # each option changes the cycle: iteration counts or iterates differ from the baseline
    base_it, base_x = seen["gs"]
    for name in ("gs5", "cheb", "W", "boomeramg"):
        it, x = seen[name]
        assert it != base_it or np.linalg.norm(x - base_x) > 1e-14 * np.linalg.norm(base_x), name
    # Galerkin coarse operators: these levels are nested FEM spaces, so the given coarse matrices
    # are already the Galerkin products and the iterates would agree to round-off. With the coarse
    # matrices doubled, the cycle that takes them changes and the Galerkin one, which replaces them
    # by the products of the finest, gives the baseline again.
    doubled = [2.0 * A for A in As[:-1]] + [As[-1]]
    gs = {"method": "pmg", "tol": 1e-8, "smoother": {"method": "gauss-seidel", "sweeps": 2}}
    x_given, given = pmgkit.multigrid(levels=doubled, prolongations=Ps, config=gs).solve(rhs)
    x_galerkin, galerkin = pmgkit.multigrid(levels=doubled, prolongations=Ps,
                                            config={**gs, "coarse_operator": "galerkin"}).solve(rhs)
    assert given["iterations"] > base_it
    assert galerkin["iterations"] == base_it
    assert np.linalg.norm(x_galerkin - base_x) <= 1e-10 * np.linalg.norm(base_x)
    with pytest.raises(pmgkit.InputError, match="sweeps"):  # Chebyshev has a degree, not sweeps
        pmgkit.multigrid(levels=As, prolongations=Ps, config={"smoother": {"method": "chebyshev", "sweeps": 3}})


def test_update_levels(levels, rhs):
    As, Ps = levels
    s = pmgkit.multigrid(levels=As, prolongations=Ps, config={"tol": 1e-10})
    x1, _ = s.solve(rhs)
    s.update([2.0 * A for A in As])
    x2, _ = s.solve(rhs)
    assert np.linalg.norm(2 * x2 - x1) / np.linalg.norm(x1) < 1e-8
    # an entry outside the pattern (the first and the last node do not touch) is refused
    n = As[-1].shape[0]
    outside = As[-1].tolil()
    outside[0, n - 1] = outside[n - 1, 0] = 1.0
    with pytest.raises(pmgkit.InputError, match="outside the pattern"):
        s.update(list(As[:-1]) + [outside.tocsr()])
    # the same entries, each row reversed, are on the pattern
    def reversed_rows(A):
        R = A.tocsr().copy()
        for i in range(R.shape[0]):
            a, b = R.indptr[i], R.indptr[i + 1]
            R.indices[a:b], R.data[a:b] = R.indices[a:b][::-1].copy(), R.data[a:b][::-1].copy()
        R.has_sorted_indices = False
        return R
    s.update([reversed_rows(A) for A in As])
    x3, _ = s.solve(rhs)
    assert np.linalg.norm(x3 - x1) / np.linalg.norm(x1) < 1e-8


def test_level_errors(levels):
    As, Ps = levels
    with pytest.raises(pmgkit.InputError, match="prolongation 2 is"):
        pmgkit.multigrid(levels=As, prolongations=[Ps[1], Ps[0]])
    with pytest.raises(pmgkit.InputError, match="prolongations"):
        pmgkit.multigrid(levels=As, prolongations=Ps[:1])
    with pytest.raises(pmgkit.InputError, match="3 unknowns per node"):
        pmgkit.multigrid(levels=[sp.identity(4, format="csr")], prolongations=[])
    with pytest.raises(pmgkit.InputError):
        pmgkit.multigrid(levels=As, finest=As[-1], prolongations=Ps)


def test_multigrid_as_scipy_preconditioner(levels, rhs):
    import scipy.sparse.linalg as spla
    As, Ps = levels
    A = As[-1].tocsr()
    M = pmgkit.multigrid(levels=As, prolongations=Ps, config={"method": "pmg", "cycles": 1}).aspreconditioner()
    it = [0]
    x, ok = spla.cg(A, rhs, M=M, tol=1e-10, atol=0, callback=lambda _: it.__setitem__(0, it[0] + 1))
    assert ok == 0 and it[0] < 30
    assert np.linalg.norm(rhs - A @ x) / np.linalg.norm(rhs) < 1.01e-10


def test_unsorted_rows_and_duplicates_are_read_in_place(levels, rhs):
    """Rows in any column order with duplicate entries (as deal.II and PETSc hand them over): the
    multigrid reads the arrays as given (no canonicalising copy) and solves as on sorted input."""
    As, Ps = levels
    b = rhs

    def scrambled(M):
        M = M.tocsr()
        indptr, cols, vals = [0], [], []
        for i in range(M.shape[0]):
            c, v = M.indices[M.indptr[i]:M.indptr[i + 1]], M.data[M.indptr[i]:M.indptr[i + 1]]
            for j, x in zip(c[::-1], v[::-1]):  # reversed, every entry split in two halves
                cols += [j, j]
                vals += [0.5 * x, 0.5 * x]
            indptr.append(len(cols))
        S = sp.csr_matrix((np.array(vals), np.array(cols, dtype=np.int32), np.array(indptr, dtype=np.int64)),
                          shape=M.shape)
        assert not S.has_canonical_format
        return S

    S = [scrambled(A) for A in As]
    x_ref, info_ref = pmgkit.multigrid(levels=As, prolongations=Ps, config={"tol": 1e-10}).solve(b)
    x, info = pmgkit.multigrid(levels=S, prolongations=[scrambled(P) for P in Ps], config={"tol": 1e-10}).solve(b)
    assert info["iterations"] == info_ref["iterations"]
    assert np.linalg.norm(x - x_ref) <= 1e-12 * np.linalg.norm(x_ref)
    indptr, indices, data, _ = pmgkit._csr_arrays(S[-1], canonical=False)
    assert indices is S[-1].indices and data is S[-1].data  # the caller's arrays, not a copy


def test_layout_component_for_any_method(levels, rhs):
    """make_solver(..., {"layout": "component"}) on a component-major matrix: the interleaved
    solve's answer, permuted."""
    As, _ = levels
    A = As[-1].tocsr()
    n = A.shape[0] // 3
    perm = component_major(n)
    Ac = A[perm][:, perm].tocsr()
    for method in ("block-jacobi-pcg", "cholmod"):
        x, info = pmgkit.make_solver(A, {"method": method}).solve(rhs)
        xc, infoc = pmgkit.make_solver(Ac, {"method": method, "layout": "component"}).solve(rhs[perm])
        assert infoc["iterations"] == info["iterations"], method
        assert np.linalg.norm(xc - x[perm]) <= 1e-10 * np.linalg.norm(x), method
    with pytest.raises(pmgkit.InputError, match="layout"):
        pmgkit.make_solver(A, {"method": "cg", "layout": "rows"})


def test_component_major_matrix_refused_by_block_methods_without_the_key(levels, rhs):
    """A component-major matrix handed to a block method without "layout" is an InputError naming
    the key (it would otherwise read mostly empty 3x3 blocks); methods that do not read blocks
    take it as it is."""
    As, _ = levels
    A = As[-1].tocsr()
    perm = component_major(A.shape[0] // 3)
    Ac = A[perm][:, perm].tocsr()
    density = Ac.nnz / Ac.shape[0] ** 2
    if density > 0.5:
        pytest.skip(f"fixture too small to be sparse ({density:.2f} of entries stored)")
    for method in ("block-jacobi-pcg", "mcg"):
        with pytest.raises(pmgkit.InputError, match="component-major.*layout=component"):
            pmgkit.make_solver(Ac, {"method": method})
    x, info = pmgkit.make_solver(Ac, {"method": "cholmod"}).solve(rhs[perm])
    assert info["residual"] < 1e-8


def test_unused_keys_for_a_shared_option_set(levels, rhs):
    """One option set for a loop over methods: "unused_keys": "known" lets a key some other method
    reads go unused (max_iterations for cholmod) and lists it; a key no method reads is still an
    error."""
    A = levels[0][-1].tocsr()
    shared = {"tol": 1e-9, "max_iterations": 5000, "unused_keys": "known"}
    for method, unused in (("block-jacobi-pcg", []), ("cholmod", ["max_iterations"])):
        s = pmgkit.make_solver(A, {"method": method, **shared})
        assert s.unused_keys == unused, method
        _, info = s.solve(rhs)
        assert info["residual"] < 1e-8
    with pytest.raises(pmgkit.InputError, match="unused key tolerance"):
        pmgkit.make_solver(A, {"method": "cholmod", "tolerance": 1e-9, "unused_keys": "known"})
    with pytest.raises(pmgkit.InputError, match="unused key max_iterations"):
        pmgkit.make_solver(A, {"method": "cholmod", "max_iterations": 5})


def test_solve_into_the_callers_array(levels, rhs):
    """out= receives the solution in place (the same object is returned); with user levels the
    reduced system is gathered from b and scattered into out; a wrong buffer is refused, never
    silently copied."""
    As, Ps = levels
    for s in (pmgkit.multigrid(levels=As, prolongations=Ps, config={"tol": 1e-10}),
              pmgkit.make_solver(As[-1].tocsr(), {"method": "block-jacobi-pcg", "tol": 1e-10})):
        x_new, _ = s.solve(rhs)
        out = np.full(rhs.size, np.nan)
        x_out, info = s.solve(rhs, out=out)
        assert x_out is out
        assert np.array_equal(out, x_new)
        out[:] = 0.0  # the start read from the array the answer goes to
        s.solve(rhs, x0=out, out=out)
        assert np.array_equal(out, x_new)
        for bad, match in ((np.zeros(rhs.size, dtype=np.float32), "float64"),
                           (np.zeros(rhs.size + 1), "shape"),
                           (np.zeros(2 * rhs.size)[::2], "contiguous")):
            with pytest.raises(pmgkit.InputError, match=match):
                s.solve(rhs, out=bad)
        with pytest.raises(pmgkit.InputError, match="NumPy array"):
            s.solve(rhs, out=[0.0] * rhs.size)  # a list would be converted, and never written
        frozen = np.zeros(rhs.size)
        frozen.flags.writeable = False
        with pytest.raises(pmgkit.InputError, match="writeable"):
            s.solve(rhs, out=frozen)
