"""Tests of the Python package: DistMesh's calls, the full API, errors, batching, meshio."""

from __future__ import annotations

import ast
import os
import signal
import sys
import threading
import time
import _thread

import numpy as np
import pytest

import trussmesh as tm
from trussmesh import _core

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "examples"))
import seed_chapter2 as seed  # noqa: E402


def tri_q(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """q = 2 r_in / r_out of each triangle."""
    a, b, c = (p[t[:, i]] for i in range(3))
    la, lb, lc = (np.linalg.norm(u - v, axis=1) for u, v in ((b, c), (c, a), (a, b)))
    return (lb + lc - la) * (lc + la - lb) * (la + lb - lc) / (la * lb * lc)


def disk(p):
    return np.sqrt((p**2).sum(axis=1)) - 1


# ============================ DistMesh's calls ============================


def test_distmesh2d_unit_disk():
    p, t = tm.distmesh2d(disk, tm.huniform, 0.1, [[-1, -1], [1, 1]])
    assert p.dtype == np.float64 and p.shape[1] == 2
    assert t.dtype == np.int64 and t.shape[1] == 3
    assert len(p) == 372 and len(t) == 682
    q = tri_q(p, t)
    assert q.min() > 0.85 and q.mean() > 0.98
    # Counter-clockwise, every point used, the area of the disk to the polygon's error.
    a, b, c = (p[t[:, i]] for i in range(3))
    area = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    assert (area > 0).all()
    assert abs(area.sum() - np.pi) < 0.02
    assert np.array_equal(np.unique(t), np.arange(len(p)))
    # Boundary nodes on the circle (projected onto the callable's own zero set).
    r = np.linalg.norm(p, axis=1)
    assert np.abs(r[r > 0.99] - 1).max() < 1e-12


def test_bbox_forms_and_fh_none_agree():
    p1, t1 = tm.distmesh2d(disk, tm.huniform, 0.2, [[-1, -1], [1, 1]])
    p2, t2 = tm.distmesh2d(disk, None, 0.2, (-1, -1, 1, 1))
    p3, t3 = tm.distmeshnd(disk, tm.huniform, 0.2, np.array([-1.0, -1, 1, 1]))
    assert np.array_equal(p1, p2) and np.array_equal(t1, t2)
    assert np.array_equal(p1, p3) and np.array_equal(t1, t3)


def test_same_input_same_output():
    fh = lambda p: 1 + np.abs(p[:, 0])  # noqa: E731
    a = tm.mesh_2d(disk, (-1, -1, 1, 1), 0.1, size=fh)
    b = tm.mesh_2d(disk, (-1, -1, 1, 1), 0.1, size=fh)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.cells, b.cells)
    c = tm.mesh_2d(disk, (-1, -1, 1, 1), 0.1, size=fh, seed=7)
    assert len(c.points) > 0


# The command line's figures on the same input (`trussmesh gallery`: nodes, q min, q mean).
CLI = {
    "ex1a": (19, 0.946, 0.971),
    "ex1b": (96, 0.913, 0.979),
    "ex1c": (372, 0.943, 0.992),
    "ex2": (327, 0.888, 0.984),
    "ex3a": (197, 0.828, 0.979),
    "ex3b": (285, 0.828, 0.973),
    "ex4": (263, 0.892, 0.987),
    "ex5": (216, 0.798, 0.976),
    "ex6": (302, 0.900, 0.989),
    "ex7": (854, 0.862, 0.991),
    "ex8": (1121, 0.824, 0.987),
    "ellipse": (186, 0.907, 0.988),
    "fig3-5": (1923, 0.663, 0.979),
}


# The sampled callable and the command line part more on two examples than the perturbation
# spread allows. ex5 (since the carve joins pinched fans at the resolution): the callable gives
# 246 nodes, q min 0.822 and q mean 0.9789, the command line 216 nodes, 0.798 and 0.976 (the node
# counts 14% apart, where 6% is allowed). ex6 (since the 2-D stall rule): q min 0.867 through the
# callable, 0.900 on the command line.
SPREAD_EXCEEDED = {
    "ex5": "open: ex5 through the sampled callable has 14% more nodes than on the command line (246 for 216)",
    "ex6": "open: ex6's q min through the sampled callable is 0.033 below the command line's (0.867 for 0.900)",
}


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(reason=SPREAD_EXCEEDED[n], strict=True))
        if n in SPREAD_EXCEEDED
        else n
        for n in CLI
    ],
)
def test_seed_examples_at_the_command_lines_quality(name):
    nodes, qmin, qmean = CLI[name]
    p, t = seed.distmesh(name)
    q = tri_q(p, t)
    # The tolerances are the command line's own spread on inputs perturbed by 1e-12 to 1e-5
    # (tests/perturbed_inputs.rs: q mean within 0.003, q min within 0.04): the sampled
    # callable differs from the expression by about that much.
    assert abs(len(p) - nodes) <= 0.06 * nodes, (len(p), nodes)
    assert q.min() >= qmin - 0.02, (q.min(), qmin)
    assert q.mean() >= qmean - 0.003, (q.mean(), qmean)
    if name not in ("ex8", "fig3-5"):
        # The seed's own criterion (section 2.7).
        assert q.min() > 0.7 and q.mean() > 0.96


@pytest.mark.xfail(reason="open defect: the corner finder's half-step test no longer finds ex8's two corners on the sampled grid of a numpy callable (feature_points 0)", strict=True)
def test_found_corners_are_on_the_callables_corners():
    # Example 8's two corners where the rectangle meets the circle are found by the mesher on
    # the sampled function, then moved onto fd's own corners.
    m = seed.run("ex8")
    assert m.report["feature_points"] == 2 and m.report["snap"]["corners"] == 2
    assert np.abs(seed.ex8_fd(m.points[m.boundary])).max() < 1e-9 * 0.02 * 100


def test_seed_internal_boundaries_label_subdomains():
    m = seed.run("fig3-5")
    assert set(np.unique(m.labels)) == {0, 1, 2}
    assert m.report["internal_nodes_off"] == 0


def test_seed_anisotropic_circle_in_its_metric():
    m = seed.run("fig3-6")
    met = m.report["metric"]
    # The command line: 96.0 % of edges in [0.707, 1.414], metric q min 0.549, mean 0.931;
    # with d perturbed by 1e-7 its q min is 0.440 (the worst element hangs on such changes).
    assert met["in_band"] > 0.95
    assert met["q_min"] >= 0.44 and met["q_mean"] >= 0.931 - 0.003


# ============================ the full API ============================


def test_expression_string_and_callable_agree():
    e = tm.mesh_2d("sqrt(x^2+y^2)-1", bbox=(-1, -1, 1, 1), h0=0.1)
    c = tm.mesh_2d(disk, bbox=(-1, -1, 1, 1), h0=0.1)
    assert e.report["sampling"] is None
    assert len(e.points) == len(c.points) == 372
    assert abs(e.report["quality"]["q_min"] - c.report["quality"]["q_min"]) < 1e-3
    assert e.report["stop"] == "at_rest" and e.report["converged"]
    assert e.report["quality"]["triangles"] == len(e.cells)
    assert "vertices" in e.report["summary"]


def test_mesh_object_and_report():
    m = tm.mesh_2d(disk, (-1, -1, 1, 1), 0.2, fixed=[[0.0, 0.0]])
    assert m.cell_type == "triangle" and m.dim == 2
    assert m.labels.shape == (len(m.cells),)
    assert m.fixed.sum() == 1 and np.allclose(m.points[m.fixed], [[0, 0]])
    assert np.allclose(np.linalg.norm(m.points[m.tags == 1], axis=1), 1, atol=1e-12)
    r = m.report
    for k in ("iterations", "converged", "stop", "seconds", "ops", "quality", "sampling", "snap"):
        assert k in r
    assert r["sampling"]["calls"] >= 1 and r["snap"]["max_abs_d_after"] < 1e-12
    assert "triangle" in repr(m)


def test_mesh_3d_unit_ball():
    m = tm.mesh_3d(lambda p: tm.dsphere(p, 0, 0, 0, 1), (-1, -1, -1, 1, 1, 1), 0.2)
    assert m.cell_type == "tetra" and m.cells.shape[1] == 4 and m.points.shape[1] == 3
    q = m.report["quality"]
    assert q["tets"] == len(m.cells) > 1500
    assert q["dihedral_min"] > 10 and q["rr_mean"] > 0.85
    a, b, c, d = (m.points[m.cells[:, i]] for i in range(4))
    vol = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6
    assert (vol > 0).all()
    assert abs(vol.sum() - 4 / 3 * np.pi) < 0.03 * 4 / 3 * np.pi
    r = np.linalg.norm(m.points[m.tags == 1], axis=1)
    assert np.abs(r - 1).max() < 1e-9


def test_distmeshnd_3d_and_expression():
    p, t = tm.distmeshnd(lambda p: tm.dsphere(p, 0, 0, 0, 1), tm.huniform, 0.3, [[-1, -1, -1], [1, 1, 1]])
    assert t.shape[1] == 4 and len(t) > 200
    e = tm.mesh_3d("sqrt(x^2+y^2+z^2)-1", (-1, -1, -1, 1, 1, 1), 0.3)
    assert e.report["quality"]["dihedral_min"] > 10
    with pytest.raises(ValueError, match="2-D and 3-D"):
        tm.distmeshnd(disk, None, 0.2, [[-1] * 4, [1] * 4])


def test_sphere_surface():
    m = tm.mesh_surface(lambda p: np.sqrt((p**2).sum(axis=1)) - 1, (-1.2, -1.2, -1.2, 1.2, 1.2, 1.2), 0.2)
    q = m.report["quality"]
    assert q["euler"] == 2 and q["closed_manifold"] and q["inward_faces"] == 0
    assert q["q_min"] > 0.5 and q["q_mean"] > 0.9
    assert np.abs(np.linalg.norm(m.points, axis=1) - 1).max() < 1e-9
    e = tm.mesh_surface("sqrt(x^2+y^2+z^2)-1", (-1.2, -1.2, -1.2, 1.2, 1.2, 1.2), 0.2)
    assert e.report["quality"]["euler"] == 2
    assert abs(len(e.points) - len(m.points)) < 0.05 * len(e.points)


def test_meshio_vtu_round_trip(tmp_path):
    meshio = pytest.importorskip("meshio")
    m = tm.mesh_2d(disk, (-1, -1, 1, 1), 0.2)
    path = tmp_path / "disk.vtu"
    with _no_fail():  # meshio warns that it pads 2-D points for VTU
        m.to_meshio().write(path)
    back = meshio.read(path)
    assert np.allclose(back.points[:, :2], m.points)
    assert np.array_equal(back.cells_dict["triangle"], m.cells)
    assert np.array_equal(back.cell_data["subdomain"][0], m.labels)
    b3 = tm.mesh_3d("sqrt(x^2+y^2+z^2)-1", (-1, -1, -1, 1, 1, 1), 0.4)
    path3 = tmp_path / "ball.vtu"
    b3.to_meshio().write(path3)
    back3 = meshio.read(path3)
    assert np.array_equal(back3.cells_dict["tetra"], b3.cells)


class _no_fail:
    def __enter__(self):
        import warnings

        self._w = warnings.catch_warnings()
        self._w.__enter__()
        warnings.simplefilter("ignore")

    def __exit__(self, *a):
        self._w.__exit__(*a)


# ============================ errors ============================


def test_bad_h0_is_a_value_error_with_the_librarys_message():
    with pytest.raises(ValueError, match="h0 must be positive and finite, got -1"):
        tm.distmesh2d(disk, tm.huniform, -1, [[-1, -1], [1, 1]])
    with pytest.raises(ValueError, match="h0 must be positive"):
        tm.mesh_3d(disk, (-1, -1, -1, 1, 1, 1), 0)
    with pytest.raises(ValueError, match="bad bounding box"):
        tm.mesh_2d(disk, (1, 1, -1, -1), 0.1)
    with pytest.raises(ValueError, match="bad bounding box"):
        tm.mesh_surface(disk, (1, 1, 1, -1, -1, -1), 0.1)
    with pytest.raises(ValueError, match="h0 must be positive"):
        tm.mesh_surface(disk, (-1, -1, -1, 1, 1, 1), float("nan"))
    with pytest.raises(ValueError, match="outside the box"):
        tm.mesh_2d(disk, (-1, -1, 1, 1), 0.1, fixed=[[3.0, 0.0]])
    with pytest.raises(ValueError, match="bad domain expression"):
        tm.mesh_2d("sqrt(x^2+y^2", (-1, -1, 1, 1), 0.1)
    with pytest.raises(ValueError, match="bbox"):
        tm.mesh_2d(disk, (-1, -1, 1), 0.1)
    with pytest.raises(TypeError):
        tm.mesh_2d(3.0, (-1, -1, 1, 1), 0.1)


def my_nan_domain(p):
    d = disk(p)
    d[p[:, 0] > 0.5] = np.nan
    return d


def test_nan_from_a_callback_names_it():
    with pytest.raises(ValueError, match=r"fd \(my_nan_domain\) returned nan at \("):
        tm.distmesh2d(my_nan_domain, tm.huniform, 0.2, [[-1, -1], [1, 1]])
    with pytest.raises(ValueError, match=r"size \(.*<lambda>\) returned inf"):
        tm.mesh_2d(disk, (-1, -1, 1, 1), 0.2, size=lambda p: np.full(len(p), np.inf))
    with pytest.raises(ValueError, match="shape"):
        tm.mesh_2d(lambda p: np.zeros((len(p), 2)), (-1, -1, 1, 1), 0.2)


class Boom(Exception):
    pass


def test_a_raising_callback_propagates():
    def fd(p):
        raise Boom("from fd")

    with pytest.raises(Boom, match="from fd"):
        tm.distmesh2d(fd, tm.huniform, 0.2, [[-1, -1], [1, 1]])

    def progress(done, total):
        if done >= 5:
            raise Boom("from progress")

    with pytest.raises(Boom, match="from progress"):
        tm.mesh_2d("sqrt(x^2+y^2)-1", (-1, -1, 1, 1), 0.05, progress=progress)


def test_progress_is_called():
    seen = []
    tm.mesh_2d("sqrt(x^2+y^2)-1", (-1, -1, 1, 1), 0.1, progress=lambda d, t: seen.append((d, t)))
    assert len(seen) > 10 and all(t >= d for d, t in seen)


def test_ctrl_c_interrupts_a_long_run():
    # A run of several seconds; SIGINT arrives after 0.3 s. Python's own handler is installed
    # for the test: a process started in the background by a shell ignores SIGINT, and then
    # interrupt_main does nothing.
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        timer = threading.Timer(0.3, _thread.interrupt_main)
        t0 = time.perf_counter()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            tm.mesh_2d("sqrt(x^2+y^2)-1", (-1, -1, 1, 1), 0.003)
        assert time.perf_counter() - t0 < 2.0
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, old)


# ============================ batching ============================


def test_callables_are_called_in_batches():
    calls = []

    def fd(p):
        calls.append(len(p))
        return disk(p)

    sizes = []

    def fh(p):
        sizes.append(len(p))
        return 1 + p[:, 0] ** 2

    m = tm.mesh_2d(fd, (-1, -1, 1, 1), 0.05, size=fh, fixed=[[0.0, 0.0]])
    s = m.report["sampling"]
    # The grid in one call each, the fixed point, then a few snapping steps.
    assert len(sizes) == 1 and sizes[0] == s["grid_nodes"]
    assert calls[0] == s["grid_nodes"] and len(calls) <= 8
    assert calls[1] == 1  # the fixed point, made exact
    assert sum(calls) + sum(sizes) == s["points"] and s["calls"] == len(calls) + len(sizes)
    assert len(m.points) > 1000


def test_large_grids_are_called_in_slabs():
    calls = []

    def fd(p):
        calls.append(len(p))
        return disk(p)

    m = tm.mesh_2d(fd, (-1, -1, 1, 1), 0.1, grid_spacing=0.001, snap=False)
    assert m.report["sampling"]["grid_nodes"] > tm.BATCH
    assert max(calls) <= tm.BATCH and len(calls) <= m.report["sampling"]["grid_nodes"] // (tm.BATCH // 2) + 1


# ============================ helpers ============================


def test_distance_helpers():
    p = np.array([[0.0, 0.0], [2.0, 0.0], [0.5, 0.5], [1.0, 1.0]])
    assert np.allclose(tm.dcircle(p, 0, 0, 1), [-1, 1, np.sqrt(0.5) - 1, np.sqrt(2) - 1])
    assert np.allclose(tm.drectangle(p, -1, 1, -1, 1)[:3], [-1, 1, -0.5])
    square = [[-1, -1], [1, -1], [1, 1], [-1, 1]]
    assert np.allclose(tm.dpoly(p, square)[:3], [-1, 1, -0.5])
    assert np.allclose(tm.dpoly(p, square + [square[0]]), tm.dpoly(p, square))
    assert tm.dpoly(np.array([[1.5, 1.5]]), square)[0] == pytest.approx(np.sqrt(0.5))
    a, b = tm.dcircle(p, 0, 0, 1), tm.dcircle(p, 1, 0, 1)
    assert np.array_equal(tm.dunion(a, b), np.minimum(a, b))
    assert np.array_equal(tm.ddiff(a, b), np.maximum(a, -b))
    assert np.array_equal(tm.dintersect(a, b), np.maximum(a, b))
    q = np.array([[0.0, 0, 0], [0, 0, 3]])
    assert np.allclose(tm.dsphere(q, 0, 0, 0, 1), [-1, 2])
    assert np.allclose(tm.dblock(q, -1, 1, -1, 1, -1, 1), [-1, 2])
    assert np.array_equal(tm.huniform(p), np.ones(4))


def test_sampled_grid_is_cubic_and_pins_points():
    x = np.linspace(-1, 1, 41)
    X, Y = np.meshgrid(x, x)
    v = X**2 - 0.5 * X * Y + 0.25 * Y
    g = _core.Sampled2(v, (-1.0, -1.0), 0.05, np.array([[0.1, 0.2]]), np.array([7.0]))
    pts = np.array([[0.61, -0.33], [0.1, 0.2]])
    val, grad = g.eval(pts)
    x0, y0 = pts[0]
    assert val[0] == pytest.approx(x0**2 - 0.5 * x0 * y0 + 0.25 * y0, abs=1e-12)
    assert np.allclose(grad[0], [2 * x0 - 0.5 * y0, -0.5 * x0 + 0.25], atol=1e-10)
    assert val[1] == pytest.approx(7.0, abs=1e-12)


# ============================ stubs ============================


def test_stubs_name_the_native_module():
    src = open(os.path.join(os.path.dirname(tm.__file__), "_core.pyi")).read()
    tree = ast.parse(src)
    stubbed = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    native = {k for k in dir(_core) if not k.startswith("_")}
    assert native - {"__version__"} <= stubbed | {"__version__"}, native - stubbed
    assert os.path.exists(os.path.join(os.path.dirname(tm.__file__), "py.typed"))
