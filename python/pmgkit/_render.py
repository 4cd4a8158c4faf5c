"""pmgkit.render — PNG stills and an animated GIF of a simulation, without ParaView.

Reads the frames of a ``pmg simulate -o DIR`` run (simulation.pvd, else frame_*.pvtu / frame_*.vtu,
else static.vtu) or a single .vtu/.pvtu file with VTK's XML readers, draws the deformed boundary
surface coloured by a field with matplotlib's Agg renderer (software, no X display: Debian's VTK
OpenGL window needs one) and writes

    OUTDIR/frame_0000.png, frame_0001.png, ...   every K-th frame (default: at most ~50 stills)
    OUTDIR/animation.gif                          the same stills, looping

Each file is written under a temporary name in OUTDIR and renamed, so an interrupted run leaves
complete files only; stills frame_NNNN.png of an earlier, longer render are removed.

    from pmgkit import render
    paths = render("out/", "pictures/", field="displacement", every=2, size=(800, 600))

    /usr/bin/python3 python/pmgkit/_render.py out/ -o pictures/ [--field displacement|von_mises] [--every K]
                                                 [--size WxH] [--view ELEV,AZIM] [--no-gif]

What is drawn, and from which arrays:
  * geometry: the rest positions (the file's points) plus the point array ``displacement`` (else
    the active point vectors), as ParaView's "Warp By Vector" does. Tetrahedra of any order (VTK
    types 10, 24, 64, 71, 78: Bézier/Lagrange cells) are drawn by their corner vertices, where a
    Bézier field equals its coefficient; points repeated across the pieces of a .pvtu are merged by
    position. Other cell types go through vtkDataSetSurfaceFilter (corners only).
  * colour: |displacement| [m], or von Mises stress [Pa] from a scalar array named like
    ``von_mises`` or a 6/9-component ``stress`` tensor (point or cell data). The colour range, the
    view and the axis limits are fixed over all drawn frames, so that the frames compare.
  * clamp and loads when the frames carry them: a point array named like ``fixed``/``clamped``
    (non-zero: a clamped node, drawn as a dark marker) and a 3-component point array named like
    ``load``/``force``/``external_force`` [N] (arrows on a subsample of the loaded nodes).
  * the frame's time (the .pvd's timestep, or a file's TimeValue field) in the title.

Errors: FileNotFoundError for a missing source or frame, ValueError for bad input (no frames, a
corrupt file, an unknown field, a field the frames lack, an OUTDIR that cannot be written); the
script prints ``render: error: ...`` and exits 2 for those, 1 for other failures.
"""
import math
import os
import re
import sys
import xml.etree.ElementTree as ElementTree

__all__ = ["render", "find_frames", "main", "FIELDS"]

#: The fields render() can colour by: name -> (colour-bar label, what the frames must carry).
FIELDS = {
    "displacement": ("|displacement| [m]", "a 3-component point array 'displacement'"),
    "von_mises": ("von Mises stress [Pa]", "a 'von_mises' scalar or a 6/9-component 'stress' array"),
    "pressure": ("pressure [Pa]", "a 'pressure' point scalar (the mixed formulation's static.vtu)"),
}

_MAX_STILLS = 50            # default every: ceil(frames / this)
_DEFAULT_VIEW = (22.0, -115.0)   # elevation, azimuth [degrees]: the -y side, the top and the x = 0 end
_MAX_ARROWS = 40
_MAX_MARKERS = 300
# Tetrahedra whose first four points are the corners: linear, quadratic, higher-order, Lagrange, Bézier.
_TET_TYPES = {10, 24, 64, 71, 78}
_FIXED_NAMES = {"fixed", "clamped", "clamp", "dirichlet", "constrained", "fixednodes", "clampednodes"}
_LOAD_NAMES = {"load", "loads", "force", "forces", "externalforce", "externalforces", "fext", "nodalforce",
               "nodalload"}
_MISES_NAMES = {"vonmises", "vonmisesstress", "mises", "misesstress", "equivalentstress"}
_STRESS_NAMES = {"stress", "cauchystress", "sigma", "stresstensor"}


def _key(name):
    return re.sub(r"[^a-z0-9]", "", name.lower())


# ---- finding the frames --------------------------------------------------------------------------

def _read_pvd(pvd):
    """[(time or None, path)] of a ParaView collection, in file order."""
    try:
        root = ElementTree.parse(pvd).getroot()
    except (ElementTree.ParseError, OSError) as e:
        raise ValueError(f"{pvd}: not a readable .pvd collection ({e})") from None
    folder = os.path.dirname(os.path.abspath(pvd))
    frames = []
    for ds in root.iter("DataSet"):
        name = ds.get("file")
        if not name:
            raise ValueError(f"{pvd}: a DataSet without a file attribute")
        try:
            t = float(ds.get("timestep")) if ds.get("timestep") is not None else None
        except ValueError:
            raise ValueError(f"{pvd}: timestep {ds.get('timestep')!r} of {name} is not a number") from None
        frames.append((t, os.path.join(folder, name)))
    if not frames:
        raise ValueError(f"{pvd}: the collection lists no frames")
    missing = [p for _, p in frames if not os.path.isfile(p)]
    if missing:
        raise FileNotFoundError(f"{pvd} lists {len(missing)} missing frame(s), first {missing[0]}")
    return frames


def find_frames(source):
    """The frames of a run folder or file, [(time or None, path)], in time order."""
    source = os.fspath(source)
    if not os.path.exists(source):
        raise FileNotFoundError(f"{source}: no such file or folder")
    if os.path.isdir(source):
        pvd = os.path.join(source, "simulation.pvd")
        if os.path.isfile(pvd):
            return _read_pvd(pvd)
        names = os.listdir(source)
        for pattern in (r"frame_(\d+)\.pvtu", r"frame_(\d+)\.vtu"):
            hits = sorted((int(m.group(1)), n) for n in names for m in [re.fullmatch(pattern, n)] if m)
            if hits:
                return [(None, os.path.join(source, n)) for _, n in hits]
        if os.path.isfile(os.path.join(source, "static.vtu")):
            return [(None, os.path.join(source, "static.vtu"))]
        raise ValueError(f"{source}: no frames here (expected simulation.pvd, frame_*.pvtu, frame_*.vtu "
                         "or static.vtu, as `pmg simulate -o DIR` writes)")
    ext = os.path.splitext(source)[1].lower()
    if ext == ".pvd":
        return _read_pvd(source)
    if ext in (".vtu", ".pvtu"):
        return [(None, source)]
    raise ValueError(f"{source}: not a .vtu, .pvtu or .pvd file, nor a folder of frames")


# ---- reading one frame ---------------------------------------------------------------------------

def _read_grid(path):
    """The vtkUnstructuredGrid of a .vtu/.pvtu; VTK's own error messages become a ValueError."""
    from vtkmodules.vtkCommonCore import vtkLogger, vtkOutputWindow, vtkStringOutputWindow
    from vtkmodules.vtkIOXML import vtkXMLPUnstructuredGridReader, vtkXMLUnstructuredGridReader

    if not os.path.isfile(path):
        raise FileNotFoundError(f"{path}: no such file")
    reader = vtkXMLPUnstructuredGridReader() if path.lower().endswith(".pvtu") else vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    # VTK reports errors on its output window and logger (stderr): collect them instead.
    previous, cutoff = vtkOutputWindow.GetInstance(), vtkLogger.GetCurrentVerbosityCutoff()
    window = vtkStringOutputWindow()
    vtkOutputWindow.SetInstance(window)
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    try:
        reader.Update()
    finally:
        vtkOutputWindow.SetInstance(previous)
        vtkLogger.SetStderrVerbosity(cutoff)
    grid = reader.GetOutput()
    errors = [line for line in window.GetOutput().splitlines() if re.match(r"vtk\w+ \(0x", line)]
    if errors or grid is None or grid.GetNumberOfCells() == 0:
        why = re.sub(r"^vtk\w+ \(0x[0-9a-f]+\): ", "", errors[0]) if errors else "no cells"
        raise ValueError(f"{path}: not a readable VTK unstructured grid ({why.strip()})")
    return grid


def _numpy(array):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    a = vtk_to_numpy(array)
    return a.reshape(len(a), -1) if a.ndim == 1 and array.GetNumberOfComponents() > 1 else a


def _arrays(data):
    """{name: numpy array} of a vtkPointData/vtkCellData."""
    out = {}
    for i in range(data.GetNumberOfArrays()):
        a = data.GetArray(i)
        if a is not None and a.GetName():
            out[a.GetName()] = _numpy(a)
    return out


def _surface(grid, points):
    """The boundary triangles, (point ids (m, 3), owning cell (m,)): tetrahedra by their corners,
    points at one position merged (the pieces of a .pvtu repeat their shared nodes)."""
    import numpy as np

    types = _numpy(grid.GetCellTypesArray()).astype(np.int64)
    if not set(np.unique(types).tolist()) <= _TET_TYPES:
        return _surface_filter(grid)
    cells = grid.GetCells()
    offsets = _numpy(cells.GetOffsetsArray()).astype(np.int64)
    conn = _numpy(cells.GetConnectivityArray()).astype(np.int64)
    corners = conn[offsets[:-1, None] + np.arange(4)]                      # (cells, 4)
    # One representative id per position (to 1e-9 of the model's size).
    used = np.unique(corners)
    x = points[used]
    scale = max(float(np.ptp(x, axis=0).max()), 1e-300)
    keys = np.round((x - x.min(axis=0)) / (scale * 1e-9)).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    rep = np.empty(points.shape[0], dtype=np.int64)
    rep[used] = used[first][inverse.ravel()]
    corners = rep[corners]
    faces = corners[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3)
    owner = np.repeat(np.arange(len(corners)), 4)
    _, index, count = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    keep = np.sort(index[count == 1])
    return faces[keep], owner[keep]


def _surface_filter(grid):
    """Boundary triangles of a grid of any cells, through vtkDataSetSurfaceFilter (corners only)."""
    import numpy as np
    from vtkmodules.vtkFiltersCore import vtkTriangleFilter
    from vtkmodules.vtkFiltersGeometry import vtkDataSetSurfaceFilter

    surf = vtkDataSetSurfaceFilter()
    surf.SetInputData(grid)
    surf.PassThroughPointIdsOn()
    surf.PassThroughCellIdsOn()
    surf.SetNonlinearSubdivisionLevel(0)
    tri = vtkTriangleFilter()
    tri.SetInputConnection(surf.GetOutputPort())
    tri.PassVertsOff()
    tri.PassLinesOff()
    tri.Update()
    poly = tri.GetOutput()
    polys = poly.GetPolys()
    conn = _numpy(polys.GetConnectivityArray()).astype(np.int64).reshape(-1, 3)
    pids = _numpy(poly.GetPointData().GetArray("vtkOriginalPointIds")).astype(np.int64)
    cids = _numpy(poly.GetCellData().GetArray("vtkOriginalCellIds")).astype(np.int64)
    if len(conn) == 0:
        raise ValueError("the grid has no boundary surface to draw")
    return pids[conn], cids[:len(conn)]


def _von_mises(s):
    import numpy as np
    s = np.asarray(s, dtype=float)
    if s.ndim == 1:
        return s
    if s.shape[1] == 1:
        return s[:, 0]
    if s.shape[1] == 6:     # xx, yy, zz and the three shear components (in any order)
        d, o = s[:, :3], s[:, 3:]
    elif s.shape[1] == 9:
        t = s.reshape(-1, 3, 3)
        d = np.stack([t[:, 0, 0], t[:, 1, 1], t[:, 2, 2]], axis=1)
        o = np.stack([0.5 * (t[:, 1, 2] + t[:, 2, 1]), 0.5 * (t[:, 0, 2] + t[:, 2, 0]),
                      0.5 * (t[:, 0, 1] + t[:, 1, 0])], axis=1)
    else:
        return None
    return np.sqrt(0.5 * ((d[:, 0] - d[:, 1]) ** 2 + (d[:, 1] - d[:, 2]) ** 2 + (d[:, 2] - d[:, 0]) ** 2)
                   + 3.0 * (o ** 2).sum(axis=1))


def _find(arrays, names, components):
    for name, a in arrays.items():
        if _key(name) in names and (a.shape[1] if a.ndim == 2 else 1) in components:
            return name
    return None


def _describe(point, cell):
    return "point arrays: %s; cell arrays: %s" % (", ".join(point) or "none", ", ".join(cell) or "none")


class _Frame:
    """What one frame contributes to the picture (the surface triangles in compact numbering)."""

    def __init__(self, time, path, vertices, triangles, values, fixed, loads):
        self.time, self.path = time, path
        self.vertices, self.triangles, self.values = vertices, triangles, values
        self.fixed, self.loads = fixed, loads   # (k, 3) positions; (positions, vectors) or None


def _load_frame(time, path, field, cache):
    import numpy as np

    grid = _read_grid(path)
    points = _numpy(grid.GetPoints().GetData()).astype(float)
    pd, cd = _arrays(grid.GetPointData()), _arrays(grid.GetCellData())
    if time is None and grid.GetFieldData().GetArray("TimeValue") is not None:
        time = float(_numpy(grid.GetFieldData().GetArray("TimeValue")).ravel()[0])

    name = "displacement" if "displacement" in pd else None
    if name is None and grid.GetPointData().GetVectors() is not None:
        name = grid.GetPointData().GetVectors().GetName()
    if name is None or pd[name].ndim != 2 or pd[name].shape[1] != 3:
        raise ValueError(f"{path}: no 3-component displacement point array to deform the mesh by "
                         f"({_describe(pd, cd)})")
    u = pd[name].astype(float)

    conn = _numpy(grid.GetCells().GetConnectivityArray())
    if cache.get("conn") is None or not np.array_equal(cache["conn"], conn) or cache["n"] != len(points):
        cache.update(conn=conn.copy(), n=len(points), surface=_surface(grid, points))
    tri, owner = cache["surface"]
    used, compact = np.unique(tri, return_inverse=True)
    compact = compact.reshape(-1, 3)
    x = points + u
    if not np.all(np.isfinite(x[used])):
        raise ValueError(f"{path}: the displacement is not finite (a diverged run?)")

    if field == "displacement":
        v = np.linalg.norm(u[used], axis=1)[compact].mean(axis=1)
    elif field == "pressure":
        # BB coefficients: at the corners (the surface's points) they are the pressure's values.
        if "pressure" not in pd or pd["pressure"].ndim != 1:
            raise ValueError(f"{path}: no 'pressure' point scalar for field pressure ({_describe(pd, cd)})")
        v = pd["pressure"].astype(float)[used][compact].mean(axis=1)
    else:
        found = None
        for arrays, at_points in ((pd, True), (cd, False)):
            key = _find(arrays, _MISES_NAMES, (1,)) or _find(arrays, _STRESS_NAMES, (1, 6, 9))
            if key is not None:
                found = (_von_mises(arrays[key]), at_points)
                break
        if found is None:
            raise ValueError(f"{path}: no stress array for field von_mises ({_describe(pd, cd)})")
        vm, at_points = found
        v = vm[used][compact].mean(axis=1) if at_points else vm[owner]

    fixed = loads = None
    clamped = np.zeros(len(points), dtype=bool)
    key = _find(pd, _FIXED_NAMES, (1, 2, 3))
    if key is not None:
        mask = np.asarray(pd[key]).reshape(len(points), -1).any(axis=1)
        clamped = mask
        ids = np.flatnonzero(mask)
        if len(ids) > _MAX_MARKERS:
            ids = ids[np.linspace(0, len(ids) - 1, _MAX_MARKERS).astype(int)]
        fixed = x[ids] if len(ids) else None
    key = _find(pd, _LOAD_NAMES, (3,))
    if key is not None:
        f = pd[key].astype(float)
        norm = np.linalg.norm(f, axis=1)
        loaded = norm > 1e-12 * max(norm.max(), 1e-300)
        # Arrows where they can be seen and where the load acts: surface vertices that are not clamped
        # (a body force also loads the interior control points, hidden inside the solid).
        visible = np.zeros(len(points), dtype=bool)
        visible[used] = True
        ids = np.flatnonzero(loaded & visible & ~clamped)
        if len(ids) == 0:
            ids = np.flatnonzero(loaded)
        if len(ids) > _MAX_ARROWS:
            ids = ids[np.linspace(0, len(ids) - 1, _MAX_ARROWS).astype(int)]
        loads = (x[ids], f[ids]) if len(ids) else None
    return _Frame(time, path, x[used], compact, np.asarray(v, dtype=float), fixed, loads)


# ---- writing -------------------------------------------------------------------------------------

def _write_atomically(target, write):
    """write(file object) into a temporary name beside target, then rename it over target (through a
    link to its target; never over a folder, device or FIFO, which a rename would replace)."""
    real = os.path.realpath(target)
    if os.path.lexists(real) and not os.path.isfile(real):
        raise ValueError(f"{target}: exists and is not a regular file; not replaced")
    tmp = os.path.join(os.path.dirname(real), ".%s.%d.tmp" % (os.path.basename(real), os.getpid()))
    try:
        with open(tmp, "wb") as f:
            write(f)
        os.replace(tmp, real)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return target


def _prepare_outdir(outdir):
    try:
        os.makedirs(outdir, exist_ok=True)
    except FileExistsError:
        raise ValueError(f"{outdir}: exists and is not a folder") from None
    except OSError as e:
        raise ValueError(f"{outdir}: cannot create the output folder ({e.strerror})") from None
    probe = os.path.join(outdir, ".render.%d.probe" % os.getpid())
    try:
        with open(probe, "wb"):
            pass
        os.unlink(probe)
    except OSError as e:
        raise ValueError(f"{outdir}: cannot write into the output folder ({e.strerror})") from None


def _shared_palette(images, cmap):
    """The RGB images mapped onto one 256-colour palette made from all of them (no flicker between
    the frames of the GIF, and a smaller file than a palette per frame): 192 colours by median cut
    of a montage of the frames, 64 from the colour map (the colour bar keeps its gradient)."""
    import numpy as np
    from PIL import Image

    picks = images[::max(1, math.ceil(len(images) / 24))]
    w, h = 240, max(1, round(240 * images[0].height / images[0].width))
    montage = Image.new("RGB", (w, h * len(picks)))
    for i, im in enumerate(picks):
        montage.paste(im.resize((w, h)), (0, h * i))
    cut = montage.quantize(colors=192, method=Image.Quantize.MEDIANCUT).getpalette()[:3 * 192]
    cut += [0] * (3 * 192 - len(cut))
    ramp = (np.asarray(cmap(np.linspace(0.0, 1.0, 64)))[:, :3] * 255).round().astype(int).ravel().tolist()
    palette = Image.new("P", (1, 1))
    palette.putpalette(cut + ramp)
    return [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]


# ---- drawing -------------------------------------------------------------------------------------

def _draw(frames, field, size, view, outdir, gif, source):
    import numpy as np
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    from PIL import Image

    # Fixed over all frames: limits, colour range, length of the load arrows.
    pts = [fr.vertices for fr in frames] + [fr.fixed for fr in frames if fr.fixed is not None]
    lo = np.min([p.min(axis=0) for p in pts], axis=0)
    hi = np.max([p.max(axis=0) for p in pts], axis=0)
    diag = float(np.linalg.norm(hi - lo)) or 1.0
    fmax = max((float(np.linalg.norm(fr.loads[1], axis=1).max()) for fr in frames
                if fr.loads is not None and len(fr.loads[1])), default=0.0)
    arrow = 0.15 * diag / fmax if fmax > 0 else 0.0
    for fr in frames:
        if fr.loads is not None and arrow > 0:
            tips = fr.loads[0] + arrow * fr.loads[1]
            lo, hi = np.minimum(lo, tips.min(axis=0)), np.maximum(hi, tips.max(axis=0))
    span = np.maximum(hi - lo, 0.02 * max(float((hi - lo).max()), 1e-12))
    center = 0.5 * (lo + hi)
    lo, hi = center - 0.52 * span, center + 0.52 * span
    vals = np.concatenate([fr.values for fr in frames])
    vals = vals[np.isfinite(vals)]
    vmin = 0.0 if field == "displacement" or not len(vals) else float(vals.min())
    vmax = float(vals.max()) if len(vals) else 1.0
    if not vmax > vmin:
        vmax = vmin + (abs(vmin) * 1e-6 or 1.0)
    norm, cmap = Normalize(vmin, vmax), colormaps["viridis"]

    # One figure and one surface collection, updated frame by frame.
    w, h = size
    fig = Figure(figsize=(w / 100.0, h / 100.0), dpi=100)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes([0.06, 0.02, 0.76, 0.92], projection="3d")
    elev, azim = view
    ax.view_init(elev=elev, azim=azim)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(span))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.tick_params(labelsize=7)
    coll = Poly3DCollection([], edgecolors=(0.0, 0.0, 0.0, 0.18), linewidths=0.25)
    ax.add_collection3d(coll)
    cax = fig.add_axes([0.86, 0.18, 0.025, 0.6])
    fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), cax=cax, label=FIELDS[field][0])
    title = fig.text(0.5, 0.955, "", ha="center", va="center", fontsize=11)
    fig.text(0.01, 0.012, os.path.basename(os.path.normpath(source)) + "  (pmgkit.render)", fontsize=7,
             color="0.4")
    legend = []
    if any(fr.fixed is not None for fr in frames):
        legend.append(Line2D([], [], ls="", marker="s", ms=4, color="0.1", label="clamped nodes"))
    if arrow > 0:
        legend.append(Line2D([], [], color="crimson", lw=1.5, label="load"))
    if legend:
        ax.legend(handles=legend, loc="upper left", fontsize=8, frameon=False)

    # Light from the viewer (a little above and to the left), shading by |cos| of the face normal.
    e, a = math.radians(elev + 25.0), math.radians(azim - 30.0)
    light = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    overlays = []
    written, images = [], []
    for i, fr in enumerate(frames):
        tris = fr.vertices[fr.triangles]                                    # (m, 3, 3)
        n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        rgba = cmap(norm(fr.values))
        rgba[:, :3] *= (0.45 + 0.55 * np.abs(n @ light))[:, None]
        # Poly3DCollection sorts the triangles by depth in the fixed view at each draw (painter's order).
        coll.set_verts(tris)
        coll.set_facecolor(rgba)
        for artist in overlays:
            artist.remove()
        overlays = []
        if fr.fixed is not None and len(fr.fixed):
            overlays.append(ax.scatter(*fr.fixed.T, s=6, c="0.1", marker="s", depthshade=False, zorder=5))
        if fr.loads is not None and arrow > 0 and len(fr.loads[0]):
            p, f = fr.loads
            overlays.append(ax.quiver(*p.T, *(arrow * f).T, color="crimson", linewidth=1.2,
                                      arrow_length_ratio=0.25, zorder=6))
        text = FIELDS[field][0].split(" [")[0]
        if fr.time is not None:
            text += "   t = %.3f s" % fr.time
        title.set_text(text + "   (frame %d of %d)" % (i + 1, len(frames)))
        canvas.draw()
        image = Image.fromarray(np.asarray(canvas.buffer_rgba())[:, :, :3].copy())
        path = os.path.join(outdir, "frame_%04d.png" % i)
        written.append(_write_atomically(path, lambda f: image.save(f, format="PNG")))
        if gif:
            images.append(image)

    if gif:
        times = [fr.time for fr in frames]
        ms = 100
        if len(frames) > 1 and None not in times and times[-1] > times[0]:
            ms = int(min(max(1000.0 * (times[-1] - times[0]) / (len(frames) - 1), 50.0), 500.0))
        images = _shared_palette(images, cmap)
        path = os.path.join(outdir, "animation.gif")
        written.append(_write_atomically(path, lambda f: images[0].save(
            f, format="GIF", save_all=True, append_images=images[1:], duration=ms, loop=0)))
    return written


# ---- the entry points ----------------------------------------------------------------------------

def render(source, outdir, field="displacement", every=None, size=(800, 600), gif=True, *, view=None):
    """Draws the frames of `source` (a `pmg simulate -o` folder, a .pvd, .vtu or .pvtu) into `outdir`.

    field: "displacement" (its magnitude), "von_mises" (needs a stress array in the frames) or
        "pressure" (a 'pressure' point scalar: the mixed formulation's output).
    every: draw every every-th frame (default: at most ~50 stills). size: (width, height) in pixels.
    gif: also write outdir/animation.gif. view: (elevation, azimuth) in degrees.
    Returns the written paths: the stills in order, then the GIF.
    """
    if field not in FIELDS:
        raise ValueError(f"unknown field {field!r}: choose one of {', '.join(FIELDS)}")
    try:
        w, h = (int(s) for s in size)
    except (TypeError, ValueError):
        raise ValueError(f"size {size!r}: expected (width, height) in pixels") from None
    if not (16 <= w <= 10000 and 16 <= h <= 10000):
        raise ValueError(f"size {w}x{h}: width and height must be within 16..10000 pixels")
    if every is not None and (isinstance(every, bool) or not isinstance(every, int) or every < 1):
        raise ValueError(f"every {every!r}: expected a whole number >= 1")
    view = _DEFAULT_VIEW if view is None else tuple(float(v) for v in view)
    if len(view) != 2 or not all(math.isfinite(v) for v in view):
        raise ValueError(f"view {view!r}: expected (elevation, azimuth) in degrees")
    source, outdir = os.fspath(source), os.fspath(outdir)

    listed = find_frames(source)
    if every is None:
        every = max(1, math.ceil(len(listed) / _MAX_STILLS))
    listed = listed[::every]
    cache = {}
    frames = [_load_frame(*listed[0], field, cache)]   # the field is there: then make the folder
    _prepare_outdir(outdir)
    frames += [_load_frame(t, p, field, cache) for t, p in listed[1:]]
    written = _draw(frames, field, (w, h), view, outdir, gif, source)
    # Stills of an earlier render that drew more frames would read as part of this one.
    for name in os.listdir(outdir):
        m = re.fullmatch(r"frame_(\d{4,})\.png", name)
        if m and int(m.group(1)) >= len(frames) and os.path.isfile(os.path.join(outdir, name)):
            os.unlink(os.path.join(outdir, name))
    return written


def _size(text):
    import argparse
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT, e.g. 800x600")
    return int(m.group(1)), int(m.group(2))


def _view(text):
    import argparse
    try:
        elev, azim = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not ELEVATION,AZIMUTH in degrees, e.g. 22,-115") from None
    return elev, azim


def _positive(text):
    import argparse
    try:
        k = int(text)
    except ValueError:
        k = 0
    if k < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number >= 1")
    return k


def main(argv=None):
    """The command line; returns the exit status (0, 2 for bad input, 1 for other failures)."""
    import argparse
    parser = argparse.ArgumentParser(
        prog="render", description="PNG stills and an animated GIF of a `pmg simulate -o DIR` run, "
        "drawn headless with matplotlib (no ParaView, no X display).")
    parser.add_argument("source", help="a `pmg simulate -o` folder, or a .pvd, .vtu or .pvtu file")
    parser.add_argument("-o", "--output", required=True, metavar="OUTDIR",
                        help="folder for frame_0000.png ... and animation.gif (created if needed)")
    parser.add_argument("--field", choices=list(FIELDS), default="displacement",
                        help="colour by |displacement| [m] or von Mises stress [Pa] (default: displacement)")
    parser.add_argument("--every", type=_positive, default=None, metavar="K",
                        help="draw every K-th frame (default: at most %d stills)" % _MAX_STILLS)
    parser.add_argument("--size", type=_size, default=(800, 600), metavar="WxH",
                        help="picture size in pixels (default: 800x600)")
    parser.add_argument("--view", type=_view, default=None, metavar="ELEV,AZIM",
                        help="camera elevation and azimuth in degrees (default: %g,%g)" % _DEFAULT_VIEW)
    parser.add_argument("--no-gif", action="store_true", help="stills only, no animation.gif")
    args = parser.parse_args(argv)
    try:
        paths = render(args.source, args.output, field=args.field, every=args.every, size=args.size,
                       gif=not args.no_gif, view=args.view)
    except (ValueError, FileNotFoundError) as e:
        print(f"render: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("render: interrupted (the files written so far are complete)", file=sys.stderr)
        return 130
    except Exception as e:  # noqa: BLE001 — one line, not a traceback, for a failure of the machine
        print(f"render: error: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
