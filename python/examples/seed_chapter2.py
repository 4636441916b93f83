"""The meshing examples of the seed's chapter 2 (Persson's thesis, section 2.5, figure 2-4,
and the 3-D examples of section 2.6), written as DistMesh users write them: numpy functions
and `distmesh2d` / `distmeshnd`. Also the seed's other 2-D examples the command line's gallery
meshes (the ellipse of figure 3-3, the internal boundaries of figure 3-5 and the anisotropic
circle of figure 3-6), through the same call with keyword options.

    python examples/seed_chapter2.py              # every example, a quality table
    python examples/seed_chapter2.py ex3b ex5     # some of them
    python examples/seed_chapter2.py --out out    # also write out/NAME.vtu (needs meshio)

The seed's 4-D ball (example 11) is left out: trussmesh meshes in 2-D and 3-D.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from typing import Any, Callable, Dict

import numpy as np

import trussmesh as tm
from trussmesh import dcircle, ddiff, dintersect, dpoly, drectangle, dunion, huniform

SQ3 = math.sqrt(3.0)


def _r(p: np.ndarray) -> np.ndarray:
    return np.sqrt((p**2).sum(axis=1))


# Example 4: a regular hexagon minus a smaller rotated one.
HEX_OUT = np.array([[math.cos(a), math.sin(a)] for a in np.arange(6) * math.pi / 3])
HEX_IN = 0.5 * np.array([[math.cos(a), math.sin(a)] for a in np.arange(6) * math.pi / 3 + math.pi / 6])


def _ex5_d1(p: np.ndarray) -> np.ndarray:
    return _r(p) - 1.0


def _ex5_d2(p: np.ndarray) -> np.ndarray:
    return np.sqrt((p[:, 0] + 0.4) ** 2 + p[:, 1] ** 2) - 0.55


def ex5_fd(p: np.ndarray) -> np.ndarray:
    return np.maximum.reduce([_ex5_d1(p), -_ex5_d2(p), -p[:, 1]])


def ex5_fh(p: np.ndarray) -> np.ndarray:
    d1, d2 = _ex5_d1(p), _ex5_d2(p)
    return np.minimum.reduce([0.15 - 0.2 * d1, 0.06 + 0.2 * d2, (d2 - d1) / 3])


def ex6_fd(p: np.ndarray) -> np.ndarray:
    f = (p[:, 0] ** 4 + p[:, 1] ** 4) ** 0.25
    return np.maximum(f - 1.0, 0.5 - f)


def ex7_fd(p: np.ndarray) -> np.ndarray:
    x, y = p[:, 0], p[:, 1]
    return np.maximum(y - np.cos(x), 5 * (2 * x / (5 * math.pi)) ** 4 - 5 - y)


def ex8_fd(p: np.ndarray) -> np.ndarray:
    return ddiff(dunion(drectangle(p, -1, 0.5, -0.5, 0.5), dcircle(p, 0.5, 0, 0.7)), dcircle(p, -0.4, 0, 0.2))


def ex8_fh(p: np.ndarray) -> np.ndarray:
    return np.minimum.reduce(
        [1 + 5 * dcircle(p, -1, -0.5, 0), 1 + 5 * dcircle(p, -1, 0.5, 0), 1 + 5 * dcircle(p, -0.4, 0, 0.2), np.full(len(p), 6.0)]
    )


FIG35_POLY = np.array([[0.15, -0.55], [0.75, -0.65], [0.65, 0.05], [0.35, 0.35], [0.1, -0.05]])


def fig35_internal(p: np.ndarray) -> np.ndarray:
    return np.minimum(dcircle(p, -0.45, 0.35, 0.35), dpoly(p, FIG35_POLY))


def fig36_metric(p: np.ndarray) -> np.ndarray:
    """M = R diag(1/h1^2, 1/h2^2) R^T: radial size h1 = min(0.01 + 0.3 (1 - r), 0.2),
    tangential h2 = 0.2."""
    x, y = p[:, 0], p[:, 1]
    r2 = x * x + y * y + 1e-300
    h1 = np.minimum(0.01 + 0.3 * (1 - np.sqrt(x * x + y * y)), 0.2)
    k = 1 / h1**2 - 25
    return np.column_stack([25 + x * x * k / r2, x * y * k / r2, 25 + y * y * k / r2])


CORNERS = [[-1, -1], [-1, 1], [1, -1], [1, 1]]

#: name -> (title, the distmesh2d arguments fd, fh, h0, bbox, pfix, keyword options).
EXAMPLES: Dict[str, Dict[str, Any]] = {
    "ex1a": dict(title="unit circle, h0 = 0.4", fd=lambda p: dcircle(p, 0, 0, 1), fh=huniform, h0=0.4, bbox=[[-1, -1], [1, 1]]),
    "ex1b": dict(title="unit circle, h0 = 0.2", fd=lambda p: dcircle(p, 0, 0, 1), fh=huniform, h0=0.2, bbox=[[-1, -1], [1, 1]]),
    "ex1c": dict(title="unit circle, h0 = 0.1", fd=lambda p: dcircle(p, 0, 0, 1), fh=huniform, h0=0.1, bbox=[[-1, -1], [1, 1]]),
    "ex2": dict(
        title="circle with a hole",
        fd=lambda p: -0.3 + np.abs(0.7 - _r(p)),
        fh=huniform,
        h0=0.1,
        bbox=[[-1, -1], [1, 1]],
    ),
    "ex3a": dict(
        title="square with a hole",
        fd=lambda p: ddiff(drectangle(p, -1, 1, -1, 1), dcircle(p, 0, 0, 0.4)),
        fh=huniform,
        h0=0.15,
        bbox=[[-1, -1], [1, 1]],
        pfix=CORNERS,
    ),
    "ex3b": dict(
        title="square with a hole, refined near the hole",
        fd=lambda p: ddiff(drectangle(p, -1, 1, -1, 1), dcircle(p, 0, 0, 0.4)),
        fh=lambda p: np.minimum(4 * _r(p) - 1, 2),
        h0=0.05,
        bbox=[[-1, -1], [1, 1]],
        pfix=CORNERS,
    ),
    "ex4": dict(
        title="hexagon minus a smaller rotated hexagon",
        fd=lambda p: ddiff(dpoly(p, HEX_OUT), dpoly(p, HEX_IN)),
        fh=huniform,
        h0=0.1,
        bbox=[[-1, -1], [1, 1]],
        pfix=np.vstack([HEX_OUT, HEX_IN]),
    ),
    "ex5": dict(
        title="geometric adaptivity",
        fd=ex5_fd,
        fh=ex5_fh,
        h0=0.05 / 3,
        bbox=[[-1, 0], [1, 1]],
        pfix=[[-1, 0], [-0.95, 0], [0.15, 0], [1, 0]],
    ),
    "ex6": dict(
        title="between level sets 0.5 and 1 of (x^4+y^4)^(1/4)",
        fd=ex6_fd,
        fh=huniform,
        h0=0.1,
        bbox=[[-1, -1], [1, 1]],
        options=dict(implicit=True),
    ),
    "ex7": dict(
        title="y <= cos(x) and y >= 5 (2x/(5 pi))^4 - 5",
        fd=ex7_fd,
        fh=huniform,
        h0=0.3,
        bbox=[[-5 * math.pi / 2, -5], [5 * math.pi / 2, 1]],
        pfix=[[-5 * math.pi / 2, 0], [5 * math.pi / 2, 0]],
        options=dict(implicit=True),
    ),
    "ex8": dict(
        title="rectangle and circle with a circular hole, graded from two corners and the hole",
        fd=ex8_fd,
        fh=ex8_fh,
        h0=0.02,
        bbox=[[-1, -0.7], [1.2, 0.7]],
        pfix=[[-1, -0.5], [-1, 0.5]],
    ),
    "ellipse": dict(
        title="ellipse x^2/4 + y^2 < 1 (implicit, figure 3-3)",
        fd=lambda p: p[:, 0] ** 2 / 4 + p[:, 1] ** 2 - 1,
        fh=huniform,
        h0=0.2,
        bbox=[[-2, -1], [2, 1]],
        options=dict(implicit=True),
    ),
    "fig3-5": dict(
        title="square with a circle and a polygon as internal boundaries",
        fd=lambda p: drectangle(p, -1, 1, -1, 1),
        fh=huniform,
        h0=0.05,
        bbox=[[-1, -1], [1, 1]],
        pfix=[[-1, -1], [1, -1], [1, 1], [-1, 1]] + FIG35_POLY.tolist(),
        options=dict(internal=fig35_internal),
    ),
    "fig3-6": dict(
        title="anisotropic unit circle: radial size min(0.01 + 0.3 (1 - r), 0.2), tangential 0.2",
        fd=lambda p: dcircle(p, 0, 0, 1),
        fh=None,
        h0=0.01,
        bbox=[[-1, -1], [1, 1]],
        options=dict(metric=fig36_metric),
    ),
}

#: The 3-D examples of section 2.6, through distmeshnd.
def ex10_fd(p: np.ndarray) -> np.ndarray:
    """Cylinder r = 1, |z| <= 1 with exact corners, minus the ball r = 0.5."""
    r, z = np.sqrt(p[:, 0] ** 2 + p[:, 1] ** 2), p[:, 2]
    d1, d2, d3 = r - 1, z - 1, -z - 1
    d4 = np.sqrt(d1**2 + d2**2)
    d5 = np.sqrt(d1**2 + d3**2)
    d = np.maximum.reduce([d1, d2, d3])
    d = np.where((d1 > 0) & (d2 > 0), d4, d)
    d = np.where((d1 > 0) & (d3 > 0), d5, d)
    return ddiff(d, tm.dsphere(p, 0, 0, 0, 0.5))


EXAMPLES_3D: Dict[str, Dict[str, Any]] = {
    "ex9": dict(title="unit ball", fd=lambda p: tm.dsphere(p, 0, 0, 0, 1), fh=huniform, h0=0.15, bbox=[[-1, -1, -1], [1, 1, 1]]),
    "ex10": dict(
        title="cylinder with a spherical hole",
        fd=ex10_fd,
        fh=lambda p: np.minimum(4 * np.sqrt((p**2).sum(axis=1)) - 1, 2),
        h0=0.1,
        bbox=[[-1, -1, -1], [1, 1, 1]],
    ),
}


def run(name: str) -> tm.Mesh:
    """Meshes one example through mesh_2d / mesh_3d (what distmesh2d / distmeshnd call), so
    that the report comes back too."""
    ex = EXAMPLES.get(name) or EXAMPLES_3D[name]
    opts = dict(ex.get("options", {}))
    mesher: Callable[..., tm.Mesh] = tm.mesh_2d if name in EXAMPLES else tm.mesh_3d
    return mesher(ex["fd"], ex["bbox"], ex["h0"], size=ex["fh"], fixed=ex.get("pfix"), **opts)


def distmesh(name: str):
    """The same example through DistMesh's call: (p, t)."""
    ex = EXAMPLES.get(name) or EXAMPLES_3D[name]
    call = tm.distmesh2d if name in EXAMPLES else tm.distmeshnd
    return call(ex["fd"], ex["fh"], ex["h0"], ex["bbox"], ex.get("pfix"), **ex.get("options", {}))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", help="examples to mesh (default: all)")
    ap.add_argument("--out", help="directory for NAME.vtu files (needs meshio)")
    a = ap.parse_args(argv)
    names = a.names or list(EXAMPLES) + list(EXAMPLES_3D)
    print("| example | nodes | cells | q min | q mean | min angle | iterations | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    for name in names:
        t0 = time.perf_counter()
        m = run(name)
        secs = time.perf_counter() - t0
        q = m.report["quality"]
        if m.cell_type == "triangle":
            qmin, qmean, ang = q["q_min"], q["q_mean"], q["angle_min"]
        else:
            qmin, qmean, ang = q["rr_min"], q["rr_mean"], q["dihedral_min"]
        print(f"| {name} | {len(m.points)} | {len(m.cells)} | {qmin:.3f} | {qmean:.3f} | {ang:.1f} | {m.report['iterations']} | {secs:.2f} |")
        if a.out:
            os.makedirs(a.out, exist_ok=True)
            m.to_meshio().write(os.path.join(a.out, f"{name}.vtu"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
