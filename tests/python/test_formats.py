"""Block formats from SciPy matrices: products into NumPy arrays without copies, conversions back."""
import numpy as np
import pytest
import scipy.sparse as sp

import pmgkit


def test_products_agree_with_scipy(levels):
    A = levels[0][-1].tocsr()
    x = np.cos(np.arange(A.shape[1]))
    y_ref = A @ x
    scale = np.abs(A) @ np.abs(x)  # each row's round-off is bounded by eps * (|A| |x|)
    for M in (pmgkit.Csr(A), pmgkit.Bcsr(A), pmgkit.Bcsr(A).to_bin_bcsr()):
        y = M.matvec(x)
        assert np.all(np.abs(y - y_ref) <= 64 * np.finfo(float).eps * scale)
        assert M.shape == A.shape


def test_out_is_written_in_place(levels):
    A = levels[0][-1].tocsr()
    B = pmgkit.Bcsr(A)
    x = np.ones(A.shape[1])
    out = np.empty(A.shape[0])
    y = B.matvec(x, out=out)
    assert np.shares_memory(y, out)
    assert np.allclose(out, A @ x, rtol=1e-12, atol=1e-9)
    with pytest.raises(pmgkit.InputError, match=r"out has shape \(3,\)"):
        B.matvec(x, out=np.empty(3))
    with pytest.raises(pmgkit.InputError, match=r"x has shape \(4,\)"):
        B.matvec(np.ones(4))


def test_conversions_back_to_scipy_view_pmgkit_storage(levels):
    A = levels[0][-1].tocsr()
    B = pmgkit.Bcsr(A)
    S = B.to_scipy()
    assert isinstance(S, sp.bsr_matrix) and S.blocksize == (3, 3)
    assert abs(S - A).max() == 0
    assert np.shares_memory(S.data, B.to_scipy().data)  # both view the same BCSR values
    C = pmgkit.Csr(A).to_scipy()
    assert abs(C - A).max() == 0
    assert B.num_blocks == S.indices.size
    with pytest.raises(pmgkit.InputError, match="multiple of the block size"):
        pmgkit.Bcsr(sp.identity(4, format="csr"))


def test_write_petsc_changes_the_named_file_only(tmp_path):
    """A link stays a link (its target is written); a FIFO without a reader is an error, not a hang;
    a device is written in place."""
    import os, stat
    v = np.arange(6.0)
    (tmp_path / "target.petsc").write_bytes(b"old")
    os.symlink("target.petsc", tmp_path / "link.petsc")
    pmgkit.write_petsc(tmp_path / "link.petsc", v)
    assert (tmp_path / "link.petsc").is_symlink()
    assert np.array_equal(pmgkit.read_petsc(tmp_path / "target.petsc"), v)
    os.mkfifo(tmp_path / "fifo")
    with pytest.raises(pmgkit.Error, match="a FIFO with no reader"):
        pmgkit.write_petsc(tmp_path / "fifo", v)
    assert stat.S_ISFIFO(os.stat(tmp_path / "fifo").st_mode)
    pmgkit.write_petsc("/dev/null", v)
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_bin_bcsr_reports_its_layout(levels):
    A = levels[0][-1]
    Bn = pmgkit.Bcsr(A).to_bin_bcsr()
    assert Bn.num_bins >= 1 and Bn.padding_ratio >= 1.0 and Bn.bytes_per_spmv > 0
    assert Bn.lanes in (1, 2, 4, 8, 16, 32) and Bn.sort_window >= 1
    assert Bn.bytes_per_spmv <= 1.1 * pmgkit.Bcsr(A).bytes_per_spmv
    x = np.linspace(-1.0, 1.0, A.shape[0])
    for lanes, window in ((1, 1), (4, 7), (32, 0)):
        B = pmgkit.Bcsr(A).to_bin_bcsr(lanes=lanes, sort_window=window)
        assert B.lanes == lanes
        np.testing.assert_allclose(B.matvec(x), A @ x, rtol=0, atol=1e-12 * abs(A @ x).max())
    with pytest.raises(pmgkit.InputError, match="lanes"):
        pmgkit.Bcsr(A).to_bin_bcsr(lanes=3)


def test_petsc_binary_round_trip_and_pmg_compare_export(pmg_bin, levels, tmp_path):
    A = levels[0][-1].tocsr()
    v = np.linspace(-1.0, 1.0, A.shape[0])
    pmgkit.write_petsc(tmp_path / "A.petsc", A)
    pmgkit.write_petsc(tmp_path / "v.petsc", v)
    B = pmgkit.read_petsc(tmp_path / "A.petsc")
    assert isinstance(B, sp.csr_matrix) and abs(B - A).max() == 0
    assert np.array_equal(pmgkit.read_petsc(tmp_path / "v.petsc"), v)
    # what the C++ tool writes, Python reads (and the reverse is the .petsc --levels route)
    from conftest import run_pmg
    run_pmg(pmg_bin, "compare", "--box", "2", "1", "1", "-p", "2", "--solvers", "cholmod",
            "--export-petsc", tmp_path / "ex")
    Ax = pmgkit.read_petsc(tmp_path / "ex" / "A.petsc")
    bx = pmgkit.read_petsc(tmp_path / "ex" / "b.petsc")
    assert Ax.shape[0] == bx.size and abs(Ax - Ax.T).max() <= 1e-12 * abs(Ax).max()
    (tmp_path / "bad.petsc").write_bytes(b"\x00\x12\x7b\x50" + b"\x00" * 5)
    with pytest.raises(pmgkit.InputError, match="bad.petsc"):
        pmgkit.read_petsc(tmp_path / "bad.petsc")
