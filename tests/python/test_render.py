"""pmgkit.render: PNG stills and an animated GIF of a short `pmg simulate` run, drawn headless, and
its refusals of bad input (exceptions from Python, `render: error:` and exit status 2 from the script)."""
import importlib
import importlib.util
import json
import math
import os
import subprocess

import numpy as np
import pytest

from conftest import ROOT, run_pmg

pytest.importorskip("vtkmodules")
pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

SCRIPT = ROOT / "python" / "pmgkit" / "_render.py"
PYTHON = "/usr/bin/python3"


def load_render_module():
    """pmgkit.render from the package (the submodule, also where pmgkit exports a render function),
    else the source file by path."""
    try:
        module = importlib.import_module("pmgkit._render")
        if callable(getattr(module, "render", None)):
            return module
    except ImportError:
        pass
    spec = importlib.util.spec_from_file_location("pmgkit_render_source", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


render_module = load_render_module()

# A bar of 4 boxes, degree 2, swinging down from a static deflection: 10 steps, a frame every 2.
SCENE = {
    "clamp": {"axis": "x", "fraction": 0.0},
    "degree": 2,
    "initial": {"state": "deflected", "force": [0.0, 0.0, -4000.0]},
    "material": {"density": 1000.0, "model": "corotational", "poisson": 0.3, "young": 5e6},
    "mesh": {"box": [4, 1, 1], "size": [4.0, 1.0, 1.0]},
    "output": {"frame_every": 2},
    "solver": {"method": "pmg", "tol": 1e-3},
    "time": {"dt": 0.02, "duration": 0.2},
}
SMALL = (240, 180)


@pytest.fixture(scope="module")
def run_dir(pmg_bin, tmp_path_factory):
    base = tmp_path_factory.mktemp("render_run")
    scene = base / "scene.json"
    scene.write_text(json.dumps(SCENE))
    out = base / "out"
    run_pmg(pmg_bin, "simulate", scene, "-o", out, "-q", "--threads", "1")
    assert (out / "simulation.pvd").is_file()
    return out


def pixels(path):
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"), dtype=float)


def run_script(*args):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([PYTHON, str(SCRIPT), *map(str, args)], capture_output=True, text=True, env=env)


def frame_files(run_dir):
    return sorted(p for p in run_dir.iterdir() if p.name.startswith("frame_") and p.suffix == ".vtu")


def test_render_writes_a_still_per_frame_and_a_gif_of_as_many_frames(run_dir, tmp_path):
    n = len(frame_files(run_dir))
    assert n == 6
    out = tmp_path / "pictures"
    written = render_module.render(run_dir, out, size=SMALL)
    stills = [out / ("frame_%04d.png" % i) for i in range(n)]
    assert [str(p) for p in written] == [str(p) for p in stills] + [str(out / "animation.gif")]
    images = [pixels(p) for p in stills]
    for p, im in zip(stills, images):
        assert im.shape == (SMALL[1], SMALL[0], 3), p
        assert im.std() > 10.0, f"{p} looks blank"
    # The bar swings: the first and the last still differ, beyond a changed title.
    assert np.abs(images[0] - images[-1]).mean() > 0.5
    with Image.open(out / "animation.gif") as gif:
        assert gif.n_frames == n and gif.size == SMALL
    assert not [p for p in out.iterdir() if p.name.startswith(".")], "temporary files left behind"


def test_every_k_draws_every_kth_frame_and_removes_stills_of_a_longer_render(run_dir, tmp_path):
    out = tmp_path / "pictures"
    render_module.render(run_dir, out, size=SMALL, gif=False)
    written = render_module.render(run_dir, out, every=4, size=SMALL, gif=False)
    assert len(written) == math.ceil(6 / 4)
    assert sorted(p.name for p in out.iterdir()) == ["frame_0000.png", "frame_0001.png"]


def test_the_script_prints_what_it_wrote(run_dir, tmp_path):
    out = tmp_path / "pictures"
    r = run_script(run_dir, "-o", out, "--every", "2", "--size", "200x150", "--no-gif")
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == [str(out / ("frame_%04d.png" % i)) for i in range(3)]
    assert not (out / "animation.gif").exists()
    with Image.open(out / "frame_0002.png") as im:
        assert im.size == (200, 150)


def test_one_vtu_file_renders_alone(run_dir, tmp_path):
    written = render_module.render(frame_files(run_dir)[-1], tmp_path / "one", size=SMALL)
    assert [os.path.basename(p) for p in written] == ["frame_0000.png", "animation.gif"]
    assert pixels(written[0]).std() > 10.0


def with_clamp_load_and_stress(src, dst):
    """A copy of a frame with a 'fixed' marker and a 'load' point array and a 'stress' cell array."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
    from vtkmodules.vtkCommonDataModel import vtkUnstructuredGrid
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader, vtkXMLUnstructuredGridWriter

    reader = vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(src))
    reader.Update()
    grid = vtkUnstructuredGrid()
    grid.DeepCopy(reader.GetOutput())
    x = vtk_to_numpy(grid.GetPoints().GetData())
    load = np.zeros_like(x)
    load[x[:, 0] > x[:, 0].max() - 1e-9, 2] = -100.0
    stress = np.random.default_rng(1).normal(size=(grid.GetNumberOfCells(), 6)) * 1e4
    for name, values, data in (("fixed", (x[:, 0] < 1e-9).astype(np.uint8), grid.GetPointData()),
                               ("load", load, grid.GetPointData()),
                               ("stress", stress, grid.GetCellData())):
        a = numpy_to_vtk(np.ascontiguousarray(values), deep=1)
        a.SetName(name)
        data.AddArray(a)
    writer = vtkXMLUnstructuredGridWriter()
    writer.SetFileName(str(dst))
    writer.SetInputData(grid)
    assert writer.Write() == 1


def test_clamp_loads_and_von_mises_are_drawn_when_the_frame_carries_them(run_dir, tmp_path):
    frame = tmp_path / "marked.vtu"
    with_clamp_load_and_stress(frame_files(run_dir)[2], frame)
    written = render_module.render(frame, tmp_path / "vm", field="von_mises", size=(400, 300), gif=False)
    im = pixels(written[0])
    # The load arrows are crimson, a colour viridis never takes.
    red = (im[:, :, 0] > 170) & (im[:, :, 1] < 70) & (im[:, :, 2] < 100)
    assert red.sum() > 20


def test_pieces_of_a_pvtu_merge_into_one_surface(run_dir, tmp_path):
    """Two pieces repeating their shared nodes draw the surface of the whole (no inner faces)."""
    from vtkmodules.vtkCommonCore import vtkIdList
    from vtkmodules.vtkFiltersExtraction import vtkExtractCells
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader, vtkXMLUnstructuredGridWriter

    src = frame_files(run_dir)[3]
    reader = vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(src))
    reader.Update()
    grid, n = reader.GetOutput(), reader.GetOutput().GetNumberOfCells()
    pieces = []
    for k, cells in enumerate((range(0, n // 2), range(n // 2, n))):
        ids = vtkIdList()
        for c in cells:
            ids.InsertNextId(c)
        extract = vtkExtractCells()
        extract.SetInputData(grid)
        extract.SetCellList(ids)
        writer = vtkXMLUnstructuredGridWriter()
        writer.SetFileName(str(tmp_path / f"frame_000000_{k}.vtu"))
        writer.SetInputConnection(extract.GetOutputPort())
        assert writer.Write() == 1
        pieces.append(f'<Piece Source="frame_000000_{k}.vtu"/>')
    (tmp_path / "frame_000000.pvtu").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="PUnstructuredGrid" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64">\n<PUnstructuredGrid GhostLevel="0">\n<PPointData Vectors="displacement">\n'
        '<PDataArray type="Float64" Name="displacement" NumberOfComponents="3"/>\n</PPointData>\n'
        '<PPoints>\n<PDataArray type="Float64" NumberOfComponents="3"/>\n</PPoints>\n'
        + "\n".join(pieces) + "\n</PUnstructuredGrid>\n</VTKFile>\n")
    assert render_module.find_frames(tmp_path) == [(None, str(tmp_path / "frame_000000.pvtu"))]
    whole = render_module._load_frame(None, str(src), "displacement", {})
    parts = render_module._load_frame(None, str(tmp_path / "frame_000000.pvtu"), "displacement", {})
    assert len(parts.triangles) == len(whole.triangles) and len(parts.vertices) == len(whole.vertices)
    written = render_module.render(tmp_path, tmp_path / "pictures", size=SMALL, gif=False)
    assert pixels(written[0]).std() > 10.0


# ---- refusals ------------------------------------------------------------------------------------

@pytest.fixture
def bad_inputs(run_dir, tmp_path):
    """name -> (source, outdir, field, what the message names)."""
    empty = tmp_path / "empty"
    empty.mkdir()
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder\n")
    corrupt = tmp_path / "corrupt.vtu"
    corrupt.write_bytes(frame_files(run_dir)[1].read_bytes()[:5000])
    out = tmp_path / "out"
    return {
        "missing source": (tmp_path / "nowhere", out, "displacement", "nowhere", FileNotFoundError),
        "folder without frames": (empty, out, "displacement", "no frames", ValueError),
        "unknown field": (run_dir, out, "temperature", "temperature", ValueError),
        "field the frames lack": (run_dir, out, "von_mises", "displacement", ValueError),
        "outdir is a file": (run_dir, a_file, "displacement", "a_file", ValueError),
        "outdir under a file": (run_dir, a_file / "sub", "displacement", "a_file", ValueError),
        "corrupt vtu": (corrupt, out, "displacement", "corrupt.vtu", ValueError),
    }


CASES = ["missing source", "folder without frames", "unknown field", "field the frames lack",
         "outdir is a file", "outdir under a file", "corrupt vtu"]


@pytest.mark.parametrize("case", CASES)
def test_render_refuses_bad_input_with_a_message_naming_it(bad_inputs, case):
    source, outdir, field, named, error = bad_inputs[case]
    with pytest.raises(error, match=named):
        render_module.render(source, outdir, field=field, size=SMALL)
    if case not in ("outdir is a file", "outdir under a file"):
        assert not outdir.exists(), "nothing is created for input that is refused"


@pytest.mark.parametrize("case", CASES)
def test_the_script_exits_2_with_one_error_line_for_bad_input(bad_inputs, case):
    source, outdir, field, named, _ = bad_inputs[case]
    r = run_script(source, "-o", outdir, "--field", field, "--size", "%dx%d" % SMALL)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Traceback" not in r.stderr
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("render: error:")
    if case != "unknown field":  # argparse names the choices instead
        assert named in last


def test_render_refuses_bad_arguments(run_dir, tmp_path):
    with pytest.raises(ValueError, match="every"):
        render_module.render(run_dir, tmp_path / "o", every=0)
    with pytest.raises(ValueError, match="size"):
        render_module.render(run_dir, tmp_path / "o", size=(8, 8))
    for args in (["--every", "0"], ["--size", "big"], ["--view", "up"]):
        r = run_script(run_dir, "-o", tmp_path / "o", *args)
        assert r.returncode == 2 and "render: error:" in r.stderr, args
    assert not (tmp_path / "o").exists()
