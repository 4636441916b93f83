"""trussmesh from Python in a page: DistMesh's call, the full API with numpy callables and with
expression strings, tetrahedra in a ball, triangles on a sphere, and meshio files.

    python examples/quickstart.py [OUTDIR]
"""

import os
import sys

import numpy as np

import trussmesh as tm

out = sys.argv[1] if len(sys.argv) > 1 else "out"
os.makedirs(out, exist_ok=True)

# DistMesh's call: a square with a hole, refined near the hole, corners fixed.
fd = lambda p: tm.ddiff(tm.drectangle(p, -1, 1, -1, 1), tm.dcircle(p, 0, 0, 0.4))  # noqa: E731
fh = lambda p: np.minimum(4 * np.sqrt((p**2).sum(axis=1)) - 1, 2)  # noqa: E731
p, t = tm.distmesh2d(fd, fh, 0.05, [[-1, -1], [1, 1]], [[-1, -1], [-1, 1], [1, -1], [1, 1]])
print(f"square with a hole: {len(p)} points, {len(t)} triangles")

# The full API: the same with expression strings (evaluated in Rust), and a report.
m = tm.mesh_2d(
    "ddiff(drectangle(x,y,-1,1,-1,1), dcircle(x,y,0,0,0.4))",
    bbox=(-1, -1, 1, 1),
    h0=0.05,
    size="min(4*sqrt(x^2+y^2)-1, 2)",
    fixed=[[-1, -1], [-1, 1], [1, -1], [1, 1]],
)
q = m.report["quality"]
print(f"  expression strings: {len(m.points)} points, q min {q['q_min']:.3f}, mean {q['q_mean']:.3f}, {m.report['stop_text']}")

# Tetrahedra in the unit ball, triangles on the unit sphere.
ball = tm.mesh_3d(lambda p: tm.dsphere(p, 0, 0, 0, 1), (-1, -1, -1, 1, 1, 1), 0.15)
q = ball.report["quality"]
print(f"ball: {len(ball.points)} points, {len(ball.cells)} tetrahedra, dihedral angles {q['dihedral_min']:.1f} to {q['dihedral_max']:.1f}")
sphere = tm.mesh_surface(lambda p: np.sqrt((p**2).sum(axis=1)) - 1, (-1.2, -1.2, -1.2, 1.2, 1.2, 1.2), 0.1)
q = sphere.report["quality"]
print(f"sphere: {len(sphere.points)} points, Euler characteristic {q['euler']}, q min {q['q_min']:.3f}")

# Files through meshio (pip install meshio).
try:
    import meshio  # noqa: F401
except ImportError:
    print("meshio is not installed: no files written")
else:
    for name, mesh in (("square", m), ("ball", ball), ("sphere", sphere)):
        path = os.path.join(out, f"{name}.vtu")
        mesh.to_meshio().write(path)
        print("wrote", path)
