"""pmgkit — p-multigrid, block-sparse formats and Bernstein–Bézier elasticity from Python.

A thin layer over the C++ library: every solver comes from its one factory (the same methods and
keys as ``pmg compare`` and scene files; ``pmgkit.methods()`` lists them), matrices are any
``scipy.sparse`` matrix, vectors NumPy arrays.

    import pmgkit
    solver = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-8,
                                    "preconditioner": {"method": "block-jacobi"}})
    x, info = solver.solve(b)                       # info: iterations, residual, history, times
    x, _ = scipy.sparse.linalg.cg(A, b, M=solver.aspreconditioner())

    mg = pmgkit.multigrid(levels=[A1, A2, A3], prolongations=[P1, P2])   # coarsest first
    x, info = mg.solve(b)

Errors raise pmgkit.InputError (a ValueError: bad shapes, unknown keys, bad layouts, a matrix a
method cannot take, such as a scalar system given to a block method or CHOLMOD's zero matrix),
pmgkit.SolveError (breakdown, divergence, stagnation: a Krylov method on a matrix that is not
positive definite) or pmgkit.Error (the base of both), with the C++ library's messages.

pmgkit needs NumPy and SciPy (Debian's /usr/bin/python3 with python3-numpy and python3-scipy) and
its compiled part, pmgkit._core, from the build tree (PYTHONPATH=<build>/python).
"""
import importlib.util
import json
import os
import sys


def _missing_numpy_or_scipy(missing):
    """The ImportError for an interpreter without NumPy or SciPy: what pmgkit needs, where to get
    them, and which interpreter this is."""
    return ImportError(
        f"pmgkit needs NumPy and SciPy, and this interpreter cannot import {missing} "
        f"({sys.executable}, Python {sys.version.split()[0]}). Debian's /usr/bin/python3 has them "
        "(apt install python3-numpy python3-scipy): run the script with it, e.g. "
        "PYTHONPATH=<build>/python /usr/bin/python3 script.py")


try:
    import numpy as np
except ImportError as _e:
    raise _missing_numpy_or_scipy("numpy") from _e
try:
    # Found, not imported: scipy.sparse is imported where a matrix first needs it.
    _scipy_found = importlib.util.find_spec("scipy") is not None
except (ImportError, ValueError):  # a broken or stubbed scipy entry in sys.modules
    _scipy_found = False
if not _scipy_found:
    raise _missing_numpy_or_scipy("scipy")


def _missing_core(error):
    """The ImportError for a pmgkit without its compiled part (pmgkit._core): not built, the source
    tree's python/ on the path instead of the build tree's, or built for another Python."""
    here = os.path.dirname(os.path.abspath(__file__))
    built = sorted(f for f in os.listdir(here) if f.startswith("_core") and f.endswith((".so", ".pyd")))
    if built:
        found = (f"{here} holds {', '.join(built)}, which this Python cannot load ({error}): it was built "
                 "for another interpreter, or a library it links is missing")
    else:
        found = f"{here} has no _core extension (not built, or this is the source tree's copy of pmgkit)"
    return ImportError(
        f"pmgkit's compiled part, pmgkit._core, did not load: {found}. Build pmgkit (cmake) and put the build "
        "tree's python folder first on the path: PYTHONPATH=<build>/python, e.g. PYTHONPATH=build/python "
        f"/usr/bin/python3 script.py (the module is built for Debian's /usr/bin/python3; this is "
        f"{sys.executable}, Python {sys.version.split()[0]}).")


try:
    from . import _core
except ImportError as _e:
    raise _missing_core(_e) from _e
from ._core import (BinBcsr, Error, InputError, Material, Mesh, SolveError, ElasticModel,
                    DegreeHierarchy, MixedElasticity)

__all__ = ["make_solver", "multigrid", "methods", "study", "study_scene", "solve_distributed", "Solver", "Csr", "Bcsr", "BinBcsr", "Mesh",
           "Material", "ElasticModel", "DegreeHierarchy", "MixedElasticity", "simulate", "read_petsc", "write_petsc",
           "Error", "InputError",
           "SolveError"]


def methods():
    """Every solver method of the factory, one dict each: name, description, component, keys (each
    a dict: key, type, default, range, description), uses_levels (needs multigrid levels), and
    needs_blocks (reads 3x3 blocks of interleaved unknowns: refuses a matrix that reads as a scalar
    system; the others take any symmetric matrix)."""
    return _core.methods()


# ---- SciPy <-> CSR arrays --------------------------------------------------------------------

def _scipy_sparse():
    import scipy.sparse
    return scipy.sparse


def _csr_arrays(A, name="matrix", canonical=True):
    """(indptr, indices, data, shape) of a SciPy sparse matrix in CSR form, without a copy when A
    already is one (float64 values, int32 or int64 indices; with canonical, sorted rows without
    duplicates — multigrid levels take rows in any order and sum duplicates themselves)."""
    sp = _scipy_sparse()
    if not sp.issparse(A):
        raise InputError(f"{name}: expected a scipy.sparse matrix, got {type(A).__name__}")
    if A.format != "csr":
        A = A.tocsr()
    _check_indptr(A, name)
    if A.dtype != np.float64:
        if np.iscomplexobj(A.data):
            raise InputError(f"{name}: complex values are not supported")
        A = A.astype(np.float64)
    if canonical and not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    return (A.indptr, A.indices, A.data, A.shape)


def _check_indptr(A, name):
    """A CSR matrix's row pointers must start at 0, never decrease and end at the entries held:
    SciPy's own routines (has_canonical_format, sum_duplicates) fail on them with a C++ error."""
    indptr = np.asarray(A.indptr)
    if indptr.ndim != 1 or indptr.size != A.shape[0] + 1:
        raise InputError(f"{name}: indptr has {indptr.size} entries, expected rows + 1 = {A.shape[0] + 1}")
    if indptr.size and indptr[0] != 0:
        raise InputError(f"{name}: indptr[0] is {int(indptr[0])}, expected 0")
    drops = np.flatnonzero(np.diff(indptr) < 0)
    if drops.size:
        raise InputError(f"{name}: row pointers decrease at row {int(drops[0])} "
                         f"(indptr {int(indptr[drops[0]])} then {int(indptr[drops[0] + 1])}): not a valid CSR matrix")
    if indptr.size and (indptr[-1] > len(A.indices) or indptr[-1] > len(A.data)):
        raise InputError(f"{name}: indptr ends at {int(indptr[-1])}, beyond the {min(len(A.indices), len(A.data))} "
                         "entries held")


def _real_vector(v, name):
    """A right-hand side, guess or vector as float64; complex values are refused (not cast away),
    an (n, 1) column is taken as a vector."""
    a = np.asarray(v)
    if np.iscomplexobj(a):
        raise InputError(f"{name}: complex values are not supported (pmgkit solves real systems; "
                         "solve the real and imaginary parts separately)")
    if a.ndim == 2 and a.shape[1] == 1:
        a = a[:, 0]
    return np.asarray(a, dtype=np.float64)


def _to_scipy_bsr(arrays):
    indptr, indices, data, shape = arrays
    return _scipy_sparse().bsr_matrix((data, indices, indptr), shape=tuple(shape), copy=False)


def _to_scipy_csr(arrays):
    indptr, indices, data, shape = arrays
    return _scipy_sparse().csr_matrix((data, indices, indptr), shape=tuple(shape), copy=False)


_MAX_CONFIG_DEPTH = 32  # a solver tree deeper than this is a mistake (the deepest real one: 4)


def _config_text(config, default_method):
    if config is None:
        config = {}
    if isinstance(config, str):
        try:
            config = json.loads(config)
        except json.JSONDecodeError as e:
            raise InputError(f"config: not valid JSON: {e}") from None
    if not isinstance(config, dict):
        raise InputError("config: expected a dict or a JSON object string")
    config = dict(config)
    config.setdefault("method", default_method)
    # Depth first, without recursion: a config nested thousands deep is refused by name, not
    # with Python's RecursionError.
    stack = [(config, "", 1)]
    while stack:
        value, path, depth = stack.pop()
        if depth > _MAX_CONFIG_DEPTH:
            raise InputError(f"config: {path or 'the config'}: nested deeper than {_MAX_CONFIG_DEPTH} levels")
        if isinstance(value, dict):
            for k, v in value.items():
                stack.append((v, f"{path}.{k}" if path else str(k), depth + 1))

    def non_finite(value, path):
        if isinstance(value, float) and not np.isfinite(value):
            return path
        if isinstance(value, dict):
            for k, v in value.items():
                found = non_finite(v, f"{path}.{k}" if path else str(k))
                if found:
                    return found
        return None

    bad = non_finite(config, "")
    if bad:
        raise InputError(f"config: {bad}: expected a finite number")
    return json.dumps(config)


# ---- solvers -----------------------------------------------------------------------------------

class Solver:
    """A solver from pmgkit's factory, set up on its matrix (or multigrid levels).

    solve(b, x0=None, tol=None, out=None) -> (x, info): see solve's own docstring for info's
        keys (residual is pmgkit's check of the answer, rel_residual the solver's own figure).
        tol, as in SciPy and PETSc, is relative to ||b||: a start x0 that meets it returns at once.
        A tol other than the config's holds for that call only (the solver is set up with it for
        the call, and again with the config's at the next call without it). Complex b or x0 are
        refused. b and x0 are
        read in place when they are contiguous float64 (any buffer NumPy can view); out, a
        contiguous writeable float64 array of the system's size, receives the solution in place
        and is returned as x (with user levels: one gather of b, one scatter into out).
    unused_keys: the config's keys the solver did not read (with "unused_keys": "known" or
        "ignore" in the config; an error otherwise).
    update(A_new): new values on the same pattern; numeric set-up only.
    aspreconditioner(): a scipy.sparse.linalg.LinearOperator applying the solver (M= of cg/gmres).
    format: the format its matrix is multiplied in (csr, bcsr, bin-bcsr or matrix-free).

    Threads: the GIL is released while the solver works, so solvers on different threads run at
    once. One Solver may be shared by several threads: its calls (solve, update, applying it) run
    one at a time. Do not modify the arrays it was built from while it is in use.
    """

    def __init__(self, core, shape, keep=()):
        self._core = core
        self.shape = shape
        self._keep = keep  # arrays the solver was built from (read in place at set-up)

    def solve(self, b, x0=None, tol=None, out=None):
        """Solves A x = b; returns (x, info).

        b: the right-hand side (float64, the system's size; complex values are refused).
        x0: the start (None: zero). tol: a tolerance relative to ||b|| for this call only (None:
        the config's). out: a contiguous writeable float64 array that receives x and is returned.

        info, a dict:
          status: "converged" (the tolerance met) or "completed" (a preconditioner's one
            correction, or fixed iterations); others only with "throw_on_failure": false.
          iterations: iterations (cycles, corrections) done.
          residual: ||b - A x|| / ||b|| for the x returned, measured by pmgkit after the solve
            (||b - A x|| itself when b = 0). A relative residual despite its name, and the number to
            check: the same measure for every method. With multigrid on user levels it is taken over
            the reduced system (the removed Dirichlet rows are exact) and divided by the norm of
            your whole b.
          rel_residual: the solver's own final relative residual, as its convergence check saw it:
            ||b - A x|| over ||b|| for iterative methods (over ||b - A x0|| when b = 0), over the
            start's residual ||b - A x0|| for direct solvers and single corrections (||b|| from
            x0 = 0); on the system the solver saw (with user levels, the reduced one). NaN where
            the method measured none (an iterative method run for a fixed number of iterations).
            Equal to residual up to rounding in the common case (an iterative method on one
            matrix, b != 0).
          history: the relative residual per iteration (entry 0 the start); history_seconds: the
            time of each entry from the start of the solve; setup_seconds, solve_seconds; method;
            message (empty when the solve succeeded).

        Raises SolveError when the solve fails (breakdown, divergence, stagnation, the iteration
        limit, a direct solve that misses its tol), InputError for bad vectors."""
        if out is not None and not isinstance(out, np.ndarray):
            raise InputError("out: expected a NumPy array (it is written in place), got %s" % type(out).__name__)
        self._check_comm()
        return self._core.solve(_real_vector(b, "b"), None if x0 is None else _real_vector(x0, "x0"), tol, out)

    def __call__(self, b):
        """x = M b (the solver applied once from x = 0)."""
        self._check_comm()
        return self._core.apply(_real_vector(b, "b"))

    def _check_comm(self):
        """A solver across ranks must not outlive its mpi4py communicator: a freed one (Free()
        sets it to MPI.COMM_NULL) is refused here, before MPI would read freed memory."""
        comm = self._keep[1] if len(self._keep) > 1 else None
        if comm is not None and hasattr(comm, "py2f"):
            from mpi4py import MPI
            if comm == MPI.COMM_NULL:
                raise InputError("comm: the communicator this solver runs on was freed (Free()); "
                                 "build a new solver on a live communicator")

    def update(self, A):
        """New values on the pattern the solver was set up on; numeric set-up only. A: a scipy
        sparse matrix with the same indptr and indices (or, for multigrid on user levels, the list
        of level matrices, coarsest first). Raises InputError for another pattern or a matrix the
        solver refuses; the solver then stays as it was."""
        if isinstance(A, (list, tuple)):
            arrays = [_csr_arrays(M, f"level matrix {i}", canonical=False) for i, M in enumerate(A)]
            self._core.update_levels(arrays)
        else:
            self._core.update(_csr_arrays(A))

    def aspreconditioner(self):
        """M as a scipy.sparse.linalg.LinearOperator: M @ x for a vector (n,) or (n, 1), and
        M @ X for a block (n, k), one application per column (SciPy's contract)."""
        from scipy.sparse.linalg import LinearOperator

        def matmat(X):
            X = np.asarray(X)
            if np.iscomplexobj(X):
                raise InputError("x: complex values are not supported")
            return np.column_stack([self(X[:, j]) for j in range(X.shape[1])]) if X.shape[1] else \
                np.zeros((self.shape[0], 0))

        return LinearOperator(self.shape, matvec=self, matmat=matmat, dtype=np.float64)

    @property
    def name(self):
        """The method's name (cg, mgpcg, ...)."""
        return self._core.name

    @property
    def format(self):
        """The format the solver multiplies its matrix in: csr, bcsr or bin-bcsr (make_solver's
        format; auto reads a matrix as 3x3 blocks only when its pattern fills them), bcsr for
        multigrid levels, or matrix-free for a hierarchy's matrix-free operator."""
        return self._core.format

    @property
    def setup_seconds(self):
        """Seconds of the last set-up (or update)."""
        return self._core.setup_seconds

    def describe(self):
        """The solver's settings in words (preconditioner, smoother, levels, ...)."""
        return self._core.describe()

    @property
    def unused_keys(self):
        """Keys of the config no part of the solver read (see the class comment)."""
        return list(self._core.unused_keys)

    @property
    def removed_nodes(self):
        """Clamped nodes (identity rows) removed from each user level, coarsest first."""
        return list(self._core.removed_nodes)

    def level_matrix(self, level):
        """A user level as the cycle sees it (free nodes, interleaved), as scipy BSR."""
        return _to_scipy_bsr(self._core.level_matrix(level))

    def level_prolongation(self, level):
        """The node prolongation from level-1 to level as the cycle sees it, as scipy CSR."""
        return _to_scipy_csr(self._core.level_prolongation(level))

    def __repr__(self):
        return repr(self._core)  # <pmgkit.Solver: method, unknowns, format[, levels]>


def make_solver(A, config=None, format="auto", coordinates=None):
    """A solver for A (any scipy.sparse matrix, symmetric) from a config dict or JSON string in
    the factory's schema ({"method": "cg", "tol": 1e-8, "preconditioner": {...}}; default
    method cg). Returns a Solver.

    format: auto | csr | bcsr | bin-bcsr. auto reads A as 3x3 blocks (BCSR) when A reads as
        blocks of interleaved unknowns (x0 y0 z0 x1 ...: the size a multiple of 3 and, for at least
        90% of the nodes, the node's three rows coupling to the same nodes, as in elasticity,
        exact zeros dropped or not), else as
        CSR: a scalar matrix (a Poisson matrix of size 12, say) stays scalar. solver.format says
        which was chosen.
    coordinates: x, y, z per node (interleaved, 3 per node) for BoomerAMG's or GAMG's
        rigid-body modes.

    Raises InputError for a bad matrix or config, and when a method that reads 3x3 blocks
    (pmgkit.methods()'s needs_blocks) gets a matrix that reads as a scalar system or as
    component-major (give {"layout": "component"} for the latter)."""
    arrays = _csr_arrays(A)
    core = _core.Solver(arrays, _config_text(config, "cg"), format,
                        None if coordinates is None else np.asarray(coordinates, dtype=np.float64))
    return Solver(core, A.shape)


def multigrid(levels=None, prolongations=(), config=None, layout="interleaved", finest=None):
    """Multigrid on the caller's levels: levels=[A_0 (coarsest), ..., A_L-1 (finest)] and
    prolongations=[P_1, ..., P_L-1] (P_l: level l-1 -> l, fine nodes x coarse nodes, or fine dofs
    x coarse dofs when it is a node prolongation applied to each component); or finest=A with the
    prolongations, the lower levels then Galerkin products. config: the factory's schema (default
    method mgpcg; pmg for the stationary cycle). layout: interleaved (x0 y0 z0 x1 ...) or
    component (x0 x1 ... y0 ...). Dirichlet identity rows (whole nodes) are removed from the
    levels and the prolongations; the solution's entries there are b / diagonal. Returns a Solver
    (its format bcsr: the cycle's levels are 3x3 blocks). Raises InputError for levels and
    prolongations that do not fit, or the wrong layout."""
    if (levels is None) == (finest is None):
        raise InputError("multigrid: give either levels=[...] (coarsest first) or finest=A")
    mats = [finest] if finest is not None else list(levels)
    arrays = [_csr_arrays(M, f"level matrix {i}", canonical=False) for i, M in enumerate(mats)]
    parrays = [_csr_arrays(P, f"prolongation {i + 1}", canonical=False) for i, P in enumerate(prolongations)]
    core = _core.Solver(arrays, parrays, _config_text(config, "mgpcg"), layout, finest is not None)
    return Solver(core, mats[-1].shape)


# ---- formats -----------------------------------------------------------------------------------

class _Format:
    """What pmgkit's matrix formats share: products and their shape."""

    def matvec(self, x, out=None):
        """y = A x; with out= (a float64 array) written in place, no allocation."""
        return self._m.matvec(x, out)

    def __matmul__(self, x):
        return self._m.matvec(np.asarray(x, dtype=np.float64), None)

    @property
    def shape(self):
        """(rows, cols)"""
        return tuple(self._m.shape)

    def __repr__(self):
        return repr(self._m)  # <pmgkit.Csr: rows x cols, nonzeros> or the Bcsr's blocks


class Csr(_Format):
    """pmgkit's CSR (64-bit row pointers) built from a scipy matrix."""

    def __init__(self, A):
        self._m = _core.Csr(_csr_arrays(A))

    def to_scipy(self):
        """A scipy csr_matrix viewing pmgkit's arrays (no copy)."""
        return _to_scipy_csr(self._m.arrays())


class Bcsr(_Format):
    """3x3-block CSR built from a scipy matrix (interleaved x, y, z per node)."""

    def __init__(self, A):
        self._m = _core.Bcsr(_csr_arrays(A))

    @property
    def num_blocks(self):
        """3x3 blocks stored."""
        return self._m.num_blocks

    @property
    def bytes_per_spmv(self):
        """The least bytes one SpMV moves (9 values and a block column per block, row pointers, x, y)."""
        return self._m.bytes_per_spmv

    def to_scipy(self):
        """A scipy bsr_matrix viewing pmgkit's arrays (no copy)."""
        return _to_scipy_bsr(self._m.arrays())

    def to_bin_bcsr(self, lanes=0, sort_window=0):
        """The BIN-BCSR form: block rows sorted by length within windows of sort_window rows,
        `lanes` threads per block row, one 32-thread bin per warp (0: chosen from the pattern)."""
        return BinBcsr(self._m, lanes, sort_window)


# ---- files ---------------------------------------------------------------------------------------

def read_petsc(path):
    """A matrix (as scipy CSR) or a vector (as a NumPy array) from PETSc's binary format (what
    MatView/VecView and `pmg compare --export-petsc` write); the header says which. Malformed
    files raise InputError naming the file."""
    import struct
    with open(path, "rb") as f:
        head = f.read(4)
    if len(head) == 4 and struct.unpack(">i", head)[0] == 1211214:  # PETSc's VEC_FILE_CLASSID
        return _core.read_petsc_vector(str(path))
    return _to_scipy_csr(_core.read_petsc_matrix(str(path)))


def write_petsc(path, obj):
    """Writes a scipy sparse matrix or a 1-D array in PETSc's binary format (to a temporary name,
    then renamed: an interrupted write leaves no half file)."""
    if _scipy_sparse().issparse(obj):
        _core.write_petsc_matrix(str(path), _csr_arrays(obj))
    else:
        _core.write_petsc_vector(str(path), np.asarray(obj, dtype=np.float64))


# ---- FEM -----------------------------------------------------------------------------------------

def _model_stiffness(self):
    """Stiffness over the free dofs (3x3 blocks, interleaved) as scipy BSR."""
    return _to_scipy_bsr(self._stiffness_arrays())


def _model_mass(self):
    """Consistent mass over the free dofs as scipy BSR."""
    return _to_scipy_bsr(self._mass_arrays())


ElasticModel._stiffness_arrays = ElasticModel.stiffness
ElasticModel._mass_arrays = ElasticModel.mass
ElasticModel.stiffness = _model_stiffness
ElasticModel.mass = _model_mass


def _hierarchy_levels(self):
    """Level matrices (free dofs, coarsest first) as scipy BSR."""
    return [_to_scipy_bsr(self.matrix(l)) for l in range(self.num_levels)]


def _hierarchy_prolongations(self):
    """Node prolongations level l-1 -> l (l = 1..L-1) as scipy CSR."""
    return [_to_scipy_csr(self.prolongation(l)) for l in range(1, self.num_levels)]


def _comm_handle(comm):
    """An mpi4py communicator's Fortran handle for the C++ side (-1: None, MPI_COMM_WORLD)."""
    if comm is None:
        return -1
    py2f = getattr(comm, "py2f", None)
    if py2f is None:
        raise InputError("comm: expected an mpi4py communicator (MPI.Comm), got %s" % type(comm).__name__)
    return int(py2f())


def _hierarchy_solver(self, config=None, comm=None):
    """A solver of the factory on this hierarchy's finest level (its free unknowns, as
    restrict_to_free gives them), set up as `pmg compare` sets up an FEM scene: multigrid methods
    take the hierarchy's degrees as their levels (default method mgpcg). With
    {"method": "petsc-mgpcg"} the p-multigrid runs across the MPI ranks of `comm` (an mpi4py
    communicator; None: MPI.COMM_WORLD): every rank of comm builds the same hierarchy, calls this
    and solve() together, gives the same b and gets all of x. The solver keeps a reference to
    comm; do not Free() it while the solver lives."""
    core = _core.Solver(self, _config_text(config, "mgpcg"), _comm_handle(comm))
    return Solver(core, (core.size, core.size), keep=(self, comm))


DegreeHierarchy.levels = _hierarchy_levels
DegreeHierarchy.prolongations = _hierarchy_prolongations
DegreeHierarchy.solver = _hierarchy_solver


def _solvers_text(solvers, default_method):
    """A study's named configurations ({"name": config} or a list of methods) as a JSON object."""
    if isinstance(solvers, (list, tuple)):
        names = [str(m) for m in solvers]
        if len(set(names)) != len(names):
            raise InputError("solvers: a method named twice in the list; name configurations in a dict instead")
        solvers = {m: {"method": m} for m in names}
    if not isinstance(solvers, dict) or not solvers:
        raise InputError("solvers: expected a non-empty dict of named configurations or a list of methods")
    return "{" + ",".join(json.dumps(str(name)) + ":" + _config_text(config, default_method)
                          for name, config in solvers.items()) + "}"


def study(system, b, solvers, reference=None, coordinates=None, format="auto", warm_up=False):
    """Several solvers on one system, as `pmg compare` runs them (the same C++ study layer): each
    is set up and solved from zero under a clock, in order, one at a time.

    system: a scipy.sparse matrix (symmetric positive definite) or a DegreeHierarchy (b then over
        its finest level's free unknowns; multigrid methods take its degrees as levels, prepared
        outside the clocks once per kind of need).
    solvers: {"name": config, ...} in the factory's schema (a list of method names is short for
        {name: {"method": name}}); default method cg for a matrix, mgpcg for a hierarchy.
    reference: the solution errors are measured against (None: no error column).
    coordinates: x, y, z per node (matrix systems; BoomerAMG's and GAMG's rigid-body modes).
    format: auto | csr | bcsr | bin-bcsr, the format the Krylov methods multiply in (matrix
        systems; auto: 3x3 blocks when the matrix reads as blocks, as in make_solver; a
        hierarchy's solvers use its BCSR levels and matrix-free operators). A method that reads
        3x3 blocks on a matrix that reads as a scalar system is an InputError before anything
        runs.
    warm_up: run each solver once untimed first (the first touch of its memory).

    Returns one dict per solver: name, config, status, message, iterations, setup_seconds,
    solve_seconds, time_to_1e-3, time_to_1e-6 (set-up included; None when not reached),
    rel_residual, rel_error, b_dot_x (bᵀx: an FEM scene's compliance), settings, breakdown,
    setup_breakdown, history (relative residual per
    iteration) and history_seconds (from the start of the solve)."""
    hierarchy = isinstance(system, DegreeHierarchy)
    text = _solvers_text(solvers, "mgpcg" if hierarchy else "cg")
    b = np.ascontiguousarray(b, dtype=np.float64)
    ref = None if reference is None else np.ascontiguousarray(reference, dtype=np.float64)
    if hierarchy:
        return _core.study_hierarchy(system, b, text, ref, bool(warm_up))
    xyz = None if coordinates is None else np.ascontiguousarray(coordinates, dtype=np.float64)
    return _core.study_matrix(_csr_arrays(system), b, text, ref, xyz, str(format), bool(warm_up))


def _scene_text(scene):
    """A scene (a dict in the scene-file schema, a JSON string, or a path) as (JSON text, origin)."""
    import os
    if isinstance(scene, dict):
        return json.dumps(scene), "scene"
    if isinstance(scene, str) and scene.lstrip().startswith("{"):
        return scene, "scene"
    path = os.fspath(scene)
    with open(path, "rb") as f:  # read no more than a scene may hold (a device never ends)
        data = f.read(_core.max_config_bytes + 1)
    if len(data) > _core.max_config_bytes:
        raise InputError("scene: '%s' is longer than %d bytes: not a scene file" % (path, _core.max_config_bytes))
    return data.decode("utf-8", errors="replace"), path


def study_scene(scene, solvers, dt=0.0, reference="direct", warm_up=False):
    """pmgkit.study on a scene's linear system, as `pmg compare` builds it from its scene options
    (the same C++ type, sim::SceneSystem): the static stiffness system K u = f, or with dt > 0 the
    system of one undamped implicit-Euler step (M + dt^2 K) v = dt f, over the free unknowns of
    the scene's finest degree, multigrid methods on its degree hierarchy. scene: a dict in the
    scene-file schema, a JSON string or a path. reference: "direct" (errors against a direct
    solve of the assembled system) or None. Returns study()'s list of dicts."""
    if reference not in ("direct", None):
        raise InputError("reference: expected \"direct\" or None")
    text, origin = _scene_text(scene)
    configs = _solvers_text(solvers, "mgpcg")
    return _core.study_scene(text, origin, configs, float(dt), reference == "direct", bool(warm_up))


def simulate(scene, output_dir="", distributed_mesh=False):
    """Runs a dynamic scene (a dict in the scene-file schema, a JSON string, or a path to a scene
    file) and returns its summary with per-step records as NumPy arrays (records: step, time,
    probe (n x 3), kinetic, elastic, total_energy, iterations, rel_residual, residual and the
    seconds of each stage). output_dir: also write steps.csv and the .vtu frames there. A scene
    with petsc-mgpcg run under mpirun steps across the ranks: every rank calls simulate with the
    same output_dir (each writes its piece of every .pvtu frame; rank 0 steps.csv). With
    distributed_mesh=True (under mpirun, the world's ranks) no rank holds the whole mesh: the scene
    is built on the ranks, as `pmg simulate --distributed-mesh` does, and stepped by petsc-mgpcg.

    A step that fails (its solve diverges, stagnates or misses the scene's tolerance) raises
    SolveError "simulation failed at step N: ...", as `pmg simulate` exits 1; the summary of the
    steps done before it is the exception's `summary` attribute."""
    text, origin = _scene_text(scene)
    out = _core.simulate(text, origin, output_dir, bool(distributed_mesh))
    if out["failure"]:
        err = SolveError("simulation failed at step %d: %s" % (out["failed_step"], out["failure"]))
        err.summary = out
        raise err
    return out


def solve_distributed(scene, comm=None, solver=None, save_mesh=""):
    """A static scene solved on a mesh no rank holds whole (what `pmg compare --distributed-mesh`
    runs): rank 0 makes the box or reads the scene's mesh file (a .h5 file in PETSc's HDF5 format is
    read by every rank in parallel), the mesh is partitioned and moved to the ranks of `comm` (an
    mpi4py communicator; None: MPI.COMM_WORLD), each rank refines its part `mesh.refine` times and
    builds its share of the degree hierarchy, clamp and loads; petsc-mgpcg solves K u = f. Every
    rank of comm calls it with the same scene. scene: a dict in the scene-file schema, a JSON
    string or a path (symmetry planes, supports and an inclusion are taken).
    solver: petsc-mgpcg's keys (default {"method": "petsc-mgpcg"}; its tol is 1e-8 unless given).
    save_mesh: also write the refined mesh there (.h5) for a later parallel read.

    Returns a dict: status, iterations, true_relative_residual, compliance (b.u, J),
    max_displacement (m), unknowns, tets, setup_seconds, solve_seconds, description, stages (list of
    (name, seconds) of this rank), history (||r_i|| / ||b|| per iteration) and owned_displacement
    (this rank's owned unknowns, in its global numbering). A solve that fails is a status, not an
    exception; bad input is an InputError on every rank."""
    text, origin = _scene_text(scene)
    return _core.solve_distributed(text, origin, _comm_handle(comm), _config_text(solver, "petsc-mgpcg"), str(save_mesh))


# ---- pictures ----------------------------------------------------------------------------------

def render(source, outdir, field="displacement", every=None, size=(800, 600), gif=True, *, view=None):
    """PNG stills and an animated GIF of a simulation, without ParaView (what `pmg render` and
    `pmg simulate --render` run).

    source: a `pmg simulate -o DIR` folder (or what `pmgkit.simulate(scene, output_dir)` wrote), a
    .pvd, .vtu or .pvtu file. outdir: where frame_0000.png, ... and animation.gif go (created).
    field: "displacement" (its magnitude) or "von_mises" (needs a stress array in the frames).
    every: draw every every-th frame (default: at most about 50 stills). size: (width, height) in
    pixels. gif: also write the animation. view: (elevation, azimuth) in degrees.
    Returns the written paths, the stills in order and then the GIF. Raises ValueError or
    FileNotFoundError naming the problem. Needs Debian's python3-vtk9, python3-matplotlib and
    python3-pil (imported only here, not by `import pmgkit`)."""
    from . import _render
    return _render.render(source, outdir, field=field, every=every, size=size, gif=gif, view=view)
