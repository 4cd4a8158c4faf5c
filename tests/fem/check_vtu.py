"""Reads pmgkit's .vtu with VTK's own XML reader and checks every sampled point: the Bezier cell's
geometry and its interpolated displacement must match what pmgkit computed; then reads the frames
of the .pvd series. Exit 77 = skipped."""
import sys

try:
    import vtk
except ImportError:
    print("python3-vtk9 is not installed: skipping")
    sys.exit(77)

directory, degree = sys.argv[1], int(sys.argv[2])
reader = vtk.vtkXMLUnstructuredGridReader()
reader.SetFileName(directory + "/sample.vtu")
reader.Update()
grid = reader.GetOutput()
npe = (degree + 1) * (degree + 2) * (degree + 3) // 6
assert grid.GetNumberOfCells() > 0, "no cells read"
for c in range(grid.GetNumberOfCells()):
    assert grid.GetCellType(c) == vtk.VTK_BEZIER_TETRAHEDRON, grid.GetCellType(c)
    assert grid.GetCell(c).GetNumberOfPoints() == npe
disp = grid.GetPointData().GetArray("displacement")
assert disp is not None and disp.GetNumberOfComponents() == 3

worst_x = worst_d = 0.0
count = 0
for line in open(directory + "/samples.csv"):
    v = [float(t) for t in line.split(",")]
    cell = grid.GetCell(int(v[0]))
    weights = [0.0] * cell.GetNumberOfPoints()
    x = [0.0, 0.0, 0.0]
    cell.EvaluateLocation(vtk.reference(0), v[1:4], x, weights)
    d = [sum(w * disp.GetComponent(cell.GetPointId(i), k) for i, w in enumerate(weights)) for k in range(3)]
    worst_x = max(worst_x, max(abs(x[k] - v[4 + k]) for k in range(3)))
    worst_d = max(worst_d, max(abs(d[k] - v[7 + k]) for k in range(3)))
    count += 1
# The .pvd collection: a well-formed XML list of (time, file) whose files VTK reads.
import xml.etree.ElementTree as ET
frames = [(float(d.get("timestep")), d.get("file")) for d in ET.parse(directory + "/series.pvd").getroot().iter("DataSet")]
assert [t for t, _ in frames] == [0.0, 0.5], frames
for _, name in frames:
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(directory + "/" + name)
    r.Update()
    assert r.GetOutput().GetNumberOfCells() == grid.GetNumberOfCells(), name

print(f"degree {degree}: {count} points, max position error {worst_x:.2e}, max displacement error {worst_d:.2e}")
sys.exit(0 if count > 0 and worst_x < 1e-12 and worst_d < 1e-12 else 1)
