"""The Python surface reads as finished: every public function, method and class of pmgkit (and of
its compiled core) has a docstring that says more than its signature and named arguments (never
arg0), every object a repr that says what it is and its sizes; `format="auto"` reads a scalar
matrix as scalar; import errors name what is missing and the interpreter."""
import inspect
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp

import pmgkit
from pmgkit import _core

DEFAULT_REPR = re.compile(r"^<[\w.]+ object at 0x[0-9a-fA-F]+>$")


def _public(module):
    """(qualified name, object) of a module's public functions and classes."""
    for name in sorted(dir(module)):
        obj = getattr(module, name)
        if name.startswith("_") or inspect.ismodule(obj):
            continue
        if inspect.isclass(obj) or callable(obj):
            yield f"{module.__name__}.{name}", obj


def _own_members(cls):
    """(name, object) of the public members pmgkit defines on a class (its bases' included, Python's
    and pybind11's own left out); properties as property objects."""
    seen = set()
    for base in cls.__mro__:
        if not getattr(base, "__module__", "").startswith("pmgkit"):
            continue
        for name in vars(base):
            if name.startswith("_") or name in seen:
                continue
            seen.add(name)
            raw = inspect.getattr_static(cls, name)
            yield name, raw if isinstance(raw, property) else getattr(cls, name)


def _everything():
    """Every public function, class and class member of pmgkit and pmgkit._core."""
    for module in (pmgkit, _core):
        for qualname, obj in _public(module):
            yield qualname, obj
            if inspect.isclass(obj):
                for name, member in _own_members(obj):
                    yield f"{qualname}.{name}", member


def _beyond_signature(doc, name):
    """A docstring without pybind11's signature lines ("name(a: int) -> T", numbered for overloads)."""
    signature = re.compile(r"^\s*(\d+\.\s+)?" + re.escape(name) + r"\(.*\)(\s*->\s*.*)?$")
    lines = [line for line in (doc or "").splitlines()
             if not signature.match(line) and line.strip() != "Overloaded function."]
    return "\n".join(lines).strip()


ALL = list(_everything())


@pytest.mark.parametrize("qualname, obj", ALL, ids=[q for q, _ in ALL])
def test_every_public_name_has_a_docstring_beyond_its_signature(qualname, obj):
    name = qualname.rsplit(".", 1)[-1]
    if isinstance(obj, property):
        assert (obj.__doc__ or "").strip(), f"{qualname}: a property without a docstring"
        return
    # Its own docstring (inspect.getdoc would fall back to a base's: RuntimeError's for Error).
    text = _beyond_signature(inspect.cleandoc(obj.__doc__ or ""), name)
    assert len(text) >= 15, f"{qualname}: no docstring beyond its signature ({obj.__doc__!r})"


def test_no_signature_or_docstring_shows_positional_placeholders():
    """Every argument is named: no arg0/arg1 in any signature, dunder methods (__init__) included."""
    found = []
    for qualname, obj in ALL:
        docs = [obj.__doc__ or ""]
        if inspect.isclass(obj):
            docs += [getattr(obj, name).__doc__ or "" for name in ("__init__", "__repr__")
                     if name in vars(obj)]
        if any(re.search(r"\barg\d+\b", d) for d in docs):
            found.append(qualname)
    assert not found, "positional placeholders (arg0) in: " + ", ".join(found)


def test_the_solve_docstring_says_what_each_residual_is():
    doc = pmgkit.Solver.solve.__doc__
    assert "residual:" in doc and "rel_residual:" in doc
    assert "measured by pmgkit after the solve" in doc and "the solver's own" in doc


# ---- reprs ---------------------------------------------------------------------------------------

def _poisson(n=12):
    """The scalar 1-D Poisson matrix (tridiagonal 2, -1): SPD, its size divisible by 3, no 3x3 blocks."""
    return sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")


@pytest.fixture(scope="module")
def samples():
    """A small real instance of every public class (exceptions aside)."""
    mesh = pmgkit.Mesh.box(2, 1, 1)
    material = pmgkit.Material(1e5, 0.3, 1e3)
    model = pmgkit.ElasticModel(mesh, 1, material)
    model.fix_vertices(lambda x: x[0] < 1e-9)
    h = pmgkit.DegreeHierarchy(mesh, 2, material, clamp=lambda x: x[0] < 1e-9)
    A = _poisson()
    K = model.stiffness()
    bcsr = pmgkit.Bcsr(K)
    solver = pmgkit.make_solver(A, {"method": "cg"})
    return {
        pmgkit.Mesh: mesh, pmgkit.Material: material, pmgkit.ElasticModel: model, pmgkit.DegreeHierarchy: h,
        pmgkit.Csr: pmgkit.Csr(A), pmgkit.Bcsr: bcsr, pmgkit.BinBcsr: bcsr.to_bin_bcsr(),
        pmgkit.Solver: solver, _core.Solver: solver._core, _core.Csr: pmgkit.Csr(A)._m, _core.Bcsr: bcsr._m,
        "multigrid": pmgkit.multigrid(levels=h.levels(), prolongations=h.prolongations()),
        "hierarchy solver": h.solver({"method": "mgpcg"}),
        pmgkit.MixedElasticity: pmgkit.MixedElasticity(mesh, 2, material, clamp=lambda x: x[0] < 1e-9),
    }


def test_every_class_has_a_repr_of_its_own(samples):
    classes = {obj for _, obj in _public(pmgkit) if inspect.isclass(obj) and not issubclass(obj, Exception)}
    classes |= {obj for _, obj in _public(_core) if inspect.isclass(obj) and not issubclass(obj, Exception)}
    missing = {c.__qualname__ for c in classes if c not in samples}
    assert not missing, f"no sample instance for {missing}: add one to samples()"
    for key, obj in samples.items():
        text = repr(obj)
        assert not DEFAULT_REPR.match(text), f"{key}: the default repr {text}"
        assert "\n" not in text and text.startswith("<pmgkit."), text


def test_reprs_give_the_sizes(samples):
    mesh, model, h = samples[pmgkit.Mesh], samples[pmgkit.ElasticModel], samples[pmgkit.DegreeHierarchy]
    assert repr(mesh) == f"<pmgkit.Mesh: {mesh.num_vertices:,} vertices, {mesh.num_tets:,} tetrahedra>"
    assert f"{model.num_dofs:,} dofs" in repr(model) and f"{model.num_free_dofs:,} free" in repr(model)
    assert f"{h.num_levels} levels" in repr(h)
    assert repr(samples[pmgkit.Csr]) == f"<pmgkit.Csr: 12x12, {samples[pmgkit.Csr].to_scipy().nnz} nonzeros>"
    assert f"{samples[pmgkit.Bcsr].num_blocks:,} 3x3 blocks" in repr(samples[pmgkit.Bcsr])
    assert repr(samples[pmgkit.Solver]) == "<pmgkit.Solver: cg, 12 unknowns, csr>"
    assert "user levels" in repr(samples["multigrid"])


def test_a_repr_builds_nothing():
    """An ElasticModel shown before its Dirichlet conditions still takes them (the repr counts the
    free unknowns without building the assembly pattern, which would freeze the fixed set)."""
    model = pmgkit.ElasticModel(pmgkit.Mesh.box(1, 1, 1), 1)
    assert "0 nodes fixed" in repr(model)
    model.fix_vertices(lambda x: x[0] < 1e-9)
    assert model.num_fixed > 0 and model.stiffness().shape[0] == model.num_free_dofs


# ---- a scalar matrix stays scalar ----------------------------------------------------------------

def test_a_scalar_matrix_of_size_divisible_by_3_is_solved_as_csr():
    A = _poisson()
    b = np.arange(1.0, 13.0)
    s = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-12})
    assert s.format == "csr"
    x, info = s.solve(b)
    assert info["status"] == "converged"
    assert np.linalg.norm(b - A @ x) <= 1e-10 * np.linalg.norm(b)


def test_elasticity_is_read_as_blocks(samples):
    K = samples[pmgkit.ElasticModel].stiffness()
    assert pmgkit.make_solver(K, {"method": "cg"}).format == "bcsr"
    assert pmgkit.make_solver(K.tocsr(), {"method": "cg"}).format == "bcsr"


def test_a_block_method_on_a_scalar_matrix_names_the_scalar_reading():
    A = _poisson()
    for fmt in ("auto", "bcsr"):
        with pytest.raises(pmgkit.InputError, match="reads as a scalar system") as e:
            pmgkit.make_solver(A, {"method": "block-jacobi-pcg"}, format=fmt)
        message = str(e.value)  # the scalar methods, where their needs are listed, and the layout key
        assert re.search(r"\(cg, ", message) and "layout=component" in message and "layout=interleaved" in message
    with pytest.raises(pmgkit.InputError, match="reads as a scalar system"):
        pmgkit.study(A, np.ones(12), ["cg", "block-jacobi-pcg"])


def test_elasticity_without_its_zero_entries_still_reads_as_blocks(samples):
    """BB elasticity on a box mesh stores exact zeros inside its nodes' 3x3 blocks: dropped
    (eliminate_zeros), each node's three rows still couple to the same nodes, so it reads as blocks;
    {"layout": "interleaved"} declares the blocks whatever the pattern."""
    K = samples[pmgkit.ElasticModel].stiffness().tocsr()
    K.eliminate_zeros()
    b = np.ones(K.shape[0])
    for config in ({"method": "block-jacobi-pcg", "tol": 1e-10},
                   {"method": "block-jacobi-pcg", "layout": "interleaved", "tol": 1e-10}):
        s = pmgkit.make_solver(K, config)
        assert s.format == "bcsr"
        x, info = s.solve(b)
        assert info["status"] == "converged" and np.linalg.norm(b - K @ x) <= 1e-8 * np.linalg.norm(b)


def test_a_component_major_elasticity_matrix_still_gets_the_layout_message():
    """Ordered before the scalar reading: a component-major matrix is named as one (layout=component)."""
    model = pmgkit.ElasticModel(pmgkit.Mesh.box(3, 1, 1), 2)
    model.fix_vertices(lambda x: x[0] < 1e-9)
    K = model.stiffness().tocsr()
    n = K.shape[0] // 3
    i = np.arange(3 * n)
    perm = 3 * (i % n) + i // n  # component-major index i -> interleaved index
    Kc = K[perm][:, perm].tocsr()
    with pytest.raises(pmgkit.InputError, match="component-major.*layout=component"):
        pmgkit.make_solver(Kc, {"method": "block-jacobi-pcg"})
    b = np.ones(K.shape[0])
    x, info = pmgkit.make_solver(Kc, {"method": "block-jacobi-pcg", "layout": "component", "tol": 1e-10}).solve(b)
    assert info["status"] == "converged" and np.linalg.norm(b - Kc @ x) <= 1e-8 * np.linalg.norm(b)


# ---- import errors -------------------------------------------------------------------------------

def _import_with(blocked):
    """`import pmgkit` in a fresh interpreter in which the module `blocked` cannot be imported."""
    path = str(pathlib.Path(pmgkit.__file__).resolve().parents[1])
    code = f"import sys; sys.modules[{blocked!r}] = None; import pmgkit"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                          env={"PYTHONPATH": path, "PATH": "/usr/bin:/bin"})


@pytest.mark.parametrize("blocked", ["numpy", "scipy"])
def test_import_without_numpy_or_scipy_says_what_pmgkit_needs(blocked):
    r = _import_with(blocked)
    assert r.returncode != 0
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: pmgkit needs NumPy and SciPy"), r.stderr
    assert "apt install python3-numpy python3-scipy" in last and "/usr/bin/python3" in last
    assert sys.executable in last and blocked in last


def test_import_without_the_compiled_part_points_at_the_build_tree():
    r = _import_with("pmgkit._core")
    assert r.returncode != 0
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: pmgkit's compiled part, pmgkit._core, did not load"), r.stderr
    assert "PYTHONPATH=<build>/python" in last and sys.executable in last
