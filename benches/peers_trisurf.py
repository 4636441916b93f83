"""Surface remeshing of triangulated input, side by side: trussmesh, mmgs and Gmsh remesh the
same closed triangle meshes at the same target edge length h, and one scorer (this file) rates
every output the same way: angles, mean q = 2 r_in / r_out, size deviation (std / mean of edge
length / h), the two-sided Hausdorff distance to the input over the input's bounding-box
diagonal, Euler characteristic, time.

    python benches/peers_trisurf.py [--trussmesh target/release/trussmesh] [--mmgs mmgs] [--out DIR]

Needs numpy, scipy, meshio and the gmsh module (the peer harness's venv has them and the mmgs
binary: `../shared/bench/peers/setup.sh`). The inputs are made here: a sphere, a bumpy blob and a
torus by trussmesh's own surface mesher, a noisy copy of the blob (every vertex moved along its
radius by up to 1% of it, like a scan), the plate-with-a-hole part (the boundary of a tet mesh of
its distance function: flat faces, 90-degree rims) and a box turned off the axes (5 x 5 squares a
face). Peers run with their defaults but for the size: mmgs `-hsiz h` (its Hausdorff parameter at
its default 0.01 and once at a tenth of it), Gmsh classifies the input at 40 degrees, rebuilds the
surfaces and meshes them with the Frontal-Delaunay algorithm at MeshSizeMin = MeshSizeMax = h.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import meshio
import numpy as np
from scipy.spatial import cKDTree

FEATURE_DEG = 40.0


# ---------------------------------------------------------------------------- reading, writing
def read_tris(path):
    m = meshio.read(path)
    tris = np.vstack([c.data for c in m.cells if c.type == "triangle"])
    used, inv = np.unique(tris.ravel(), return_inverse=True)
    return np.asarray(m.points[used, :3], float), inv.reshape(-1, 3)


def write_stl(path, P, T):
    meshio.write(path, meshio.Mesh(P, [("triangle", T)]), file_format="stl", binary=True)


def write_medit(path, P, T):
    with open(path, "w") as f:
        f.write("MeshVersionFormatted 2\nDimension 3\nVertices\n%d\n" % len(P))
        for p in P:
            f.write("%.17g %.17g %.17g 0\n" % tuple(p))
        f.write("Triangles\n%d\n" % len(T))
        for t in T:
            f.write("%d %d %d 0\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
        f.write("End\n")


def read_medit(path):
    lines = open(path).read().split("\n")
    P, T, i = [], [], 0
    while i < len(lines):
        key = lines[i].strip()
        if key == "Vertices":
            n = int(lines[i + 1])
            P = [list(map(float, lines[i + 2 + k].split()[:3])) for k in range(n)]
            i += 2 + n
        elif key == "Triangles":
            n = int(lines[i + 1])
            T = [[int(x) - 1 for x in lines[i + 2 + k].split()[:3]] for k in range(n)]
            i += 2 + n
        else:
            i += 1
    P, T = np.array(P), np.array(T)
    used, inv = np.unique(T.ravel(), return_inverse=True)
    return P[used], inv.reshape(-1, 3)


# ---------------------------------------------------------------------------- the scorer
def closest_on_triangles(p, a, b, c):
    """Closest points on triangles (a, b, c) to points p, row by row (Ericson, Real-Time
    Collision Detection, 5.1.5, vectorised)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    out = np.empty_like(p)
    done = np.zeros(len(p), bool)

    def put(mask, val):
        nonlocal done
        mask = mask & ~done
        out[mask] = val[mask]
        done |= mask

    with np.errstate(divide="ignore", invalid="ignore"):
        put((d1 <= 0) & (d2 <= 0), a)
        put((d3 >= 0) & (d4 <= d3), b)
        put((d6 >= 0) & (d5 <= d6), c)
        v = d1 / (d1 - d3)
        put((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + v[:, None] * ab)
        w = d2 / (d2 - d6)
        put((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + w[:, None] * ac)
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        put((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + w[:, None] * (c - b))
        den = 1.0 / (va + vb + vc)
        v, w = vb * den, vc * den
        put(np.ones(len(p), bool), a + v[:, None] * ab + w[:, None] * ac)
    return out


def distance_to_mesh(q, P, T, k=24):
    """Distance from points q to the triangle mesh (P, T): exact over the k triangles whose
    centroids are nearest (triangles of comparable size)."""
    cen = P[T].mean(axis=1)
    k = min(k, len(T))
    _, idx = cKDTree(cen).query(q, k=k)
    idx = idx.reshape(len(q), k)
    best = np.full(len(q), np.inf)
    for j in range(k):
        t = T[idx[:, j]]
        x = closest_on_triangles(q, P[t[:, 0]], P[t[:, 1]], P[t[:, 2]])
        best = np.minimum(best, np.linalg.norm(x - q, axis=1))
    return best


def samples(P, T, per=6, seed=1):
    """Vertices, edge midpoints, centroids and `per` random points in every triangle."""
    rng = np.random.default_rng(seed)
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    pts = [P, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a), (a + b + c) / 3]
    for _ in range(per):
        r = rng.random((len(T), 2))
        flip = r.sum(1) > 1
        r[flip] = 1 - r[flip]
        pts.append(a + r[:, :1] * (b - a) + r[:, 1:] * (c - a))
    return np.vstack(pts)


def score(P, T, h, Pin, Tin):
    a, b, c = P[T[:, 0]], P[T[:, 1]], P[T[:, 2]]
    la, lb, lc = np.linalg.norm(b - c, axis=1), np.linalg.norm(c - a, axis=1), np.linalg.norm(a - b, axis=1)
    q = (lb + lc - la) * (lc + la - lb) * (la + lb - lc) / (la * lb * lc)
    ang = []
    for x, y, z in ((la, lb, lc), (lb, lc, la), (lc, la, lb)):
        ang.append(np.degrees(np.arccos(np.clip((y * y + z * z - x * x) / (2 * y * z), -1, 1))))
    ang = np.array(ang)
    e = np.sort(np.vstack([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    r = np.linalg.norm(P[e[:, 0]] - P[e[:, 1]], axis=1) / h
    diag = np.linalg.norm(Pin.max(0) - Pin.min(0))
    d_out = distance_to_mesh(samples(P, T), Pin, Tin).max()
    d_in = distance_to_mesh(samples(Pin, Tin), P, T).max()
    return {
        "triangles": int(len(T)),
        "min_angle": float(ang.min()),
        "max_angle": float(ang.max()),
        "mean_q": float(q.mean()),
        "size_dev": float(r.std() / r.mean()),
        "edge_over_h": float(r.mean()),
        "hausdorff": float(max(d_out, d_in) / diag),
        "euler": int(len(P) - len(e) + len(T)),
    }


# ---------------------------------------------------------------------------- the inputs
def run(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw)


def implicit_surface(tm, phi, bbox, h0, path):
    run([tm, "surface", "--phi", phi, "--bbox", bbox, "--h0", str(h0), "-q", "-o", path])


def boundary_of_tets(path):
    m = meshio.read(path)
    P = np.asarray(m.points, float)
    tets = np.vstack([c.data for c in m.cells if c.type == "tetra"])
    faces = {}
    for t in tets:
        for i in range(4):
            f = [t[j] for j in range(4) if j != i]
            key = tuple(sorted(f))
            faces[key] = None if key in faces else (f, t[i])
    T = []
    for v in faces.values():
        if v is None:
            continue
        f, opp = v
        n = np.cross(P[f[1]] - P[f[0]], P[f[2]] - P[f[0]])
        T.append(f if np.dot(n, P[opp] - P[f[0]]) < 0 else [f[0], f[2], f[1]])
    T = np.array(T)
    used, inv = np.unique(T.ravel(), return_inverse=True)
    return P[used], inv.reshape(-1, 3)


def turned_box(n=5, half=(0.9, 0.75, 0.65), axis=(0.3, -0.5, 0.8), angle=0.7):
    axis = np.array(axis) / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    index, P, T = {}, [], []

    def vid(l):
        if l not in index:
            u = np.array(l, float) * (2.0 / n) - 1.0
            P.append(R @ (u * np.array(half)))
            index[l] = len(P) - 1
        return index[l]

    for ax in range(3):
        o0, o1 = (ax + 1) % 3, (ax + 2) % 3
        for side in (0, n):
            for i in range(n):
                for j in range(n):
                    def at(a, b):
                        l = [0, 0, 0]
                        l[ax], l[o0], l[o1] = side, a, b
                        return tuple(l)
                    qd = [vid(at(i, j)), vid(at(i + 1, j)), vid(at(i + 1, j + 1)), vid(at(i, j + 1))]
                    if side == n:
                        T += [[qd[0], qd[1], qd[2]], [qd[0], qd[2], qd[3]]]
                    else:
                        T += [[qd[0], qd[2], qd[1]], [qd[0], qd[3], qd[2]]]
    return np.array(P), np.array(T)


def make_inputs(tm, d):
    inputs = []
    box = "-1.3,-1.3,-1.3,1.3,1.3,1.3"
    sphere = os.path.join(d, "sphere.stl")
    implicit_surface(tm, "sqrt(x^2+y^2+z^2)-1", box, 0.05, sphere)
    inputs.append(("sphere", sphere, 0.12, False))
    blob = os.path.join(d, "blob.stl")
    implicit_surface(tm, "sqrt(x^2+y^2+z^2)-1-0.15*sin(3*x)*sin(3*y)*sin(3*z)", "-1.4,-1.4,-1.4,1.4,1.4,1.4", 0.04, blob)
    inputs.append(("bumpy blob", blob, 0.1, False))
    P, T = read_tris(blob)
    rng = np.random.default_rng(7)
    P = P * (1 + 0.01 * rng.uniform(-1, 1, (len(P), 1)))
    noisy = os.path.join(d, "noisy_blob.stl")
    write_stl(noisy, P, T)
    inputs.append(("noisy blob (1% radial noise)", noisy, 0.1, False))
    torus = os.path.join(d, "torus.stl")
    implicit_surface(tm, "sqrt((sqrt(x^2+y^2)-1)^2+z^2)-0.35", "-1.5,-1.5,-0.5,1.5,1.5,0.5", 0.05, torus)
    inputs.append(("torus", torus, 0.08, False))
    vtu = os.path.join(d, "part_tets.vtu")
    run([tm, "mesh", "--dim", "3", "--domain", "max(max(max(abs(x)-1,abs(y)-1),abs(z)-0.5),0.4-sqrt(x^2+y^2))",
         "--bbox", "-1.1,-1.1,-0.6,1.1,1.1,0.6", "--h0", "0.06", "-q", "-o", vtu])
    part = os.path.join(d, "part.stl")
    write_stl(part, *boundary_of_tets(vtu))
    inputs.append(("plate with a hole (sharp)", part, 0.1, True))
    tbox = os.path.join(d, "turned_box.stl")
    write_stl(tbox, *turned_box())
    inputs.append(("turned box (sharp)", tbox, 0.1, True))
    return inputs


# ---------------------------------------------------------------------------- the meshers
def p_trussmesh(tm, src, h, out):
    t = time.perf_counter()
    run([tm, "surface", "--input", src, "--h0", str(h), "-q", "-o", out])
    return time.perf_counter() - t


def p_mmgs(mmgs, src, h, out, hausd=None):
    P, T = read_tris(src)
    base = out[: -len(".mesh")]
    write_medit(base + "_in.mesh", P, T)
    args = [mmgs, "-v", "-1", "-in", base + "_in.mesh", "-hsiz", str(h), "-out", out]
    if hausd is not None:
        args += ["-hausd", str(hausd)]
    t = time.perf_counter()
    run(args)
    return time.perf_counter() - t


def p_gmsh(src, h, out):
    import gmsh

    t = time.perf_counter()
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.merge(src)
        gmsh.model.mesh.classifySurfaces(FEATURE_DEG * math.pi / 180, True, True, math.pi)
        gmsh.model.mesh.createGeometry()
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        gmsh.write(out)
    finally:
        gmsh.finalize()
    return time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trussmesh", default="target/release/trussmesh")
    ap.add_argument("--mmgs", default="mmgs")
    ap.add_argument("--out", default="out/peers_trisurf")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    inputs = make_inputs(a.trussmesh, a.out)
    rows = []
    print("| input | h | mesher | triangles | min angle | max angle | mean q | size dev | edge / h | Hausdorff / diag | chi (input) | s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, src, h, sharp in inputs:
        Pin, Tin = read_tris(src)
        chi_in = score(Pin, Tin, h, Pin, Tin)["euler"]
        diag = np.linalg.norm(Pin.max(0) - Pin.min(0))
        stem = os.path.join(a.out, os.path.splitext(os.path.basename(src))[0])
        runs = [
            ("trussmesh", lambda o: p_trussmesh(a.trussmesh, src, h, o), stem + "_trussmesh.stl", None),
            ("mmgs (hausd 0.01)", lambda o: p_mmgs(a.mmgs, src, h, o), stem + "_mmgs.mesh", "medit"),
            ("mmgs (hausd 0.001)", lambda o: p_mmgs(a.mmgs, src, h, o, 0.001), stem + "_mmgs_fine.mesh", "medit"),
            ("gmsh frontal-delaunay", lambda o: p_gmsh(src, h, o), stem + "_gmsh.msh", None),
        ]
        for mesher, go, out, fmt in runs:
            try:
                secs = go(out)
                P, T = read_medit(out) if fmt == "medit" else read_tris(out)
                s = score(P, T, h, Pin, Tin)
            except Exception as e:  # a peer that fails is a row that says so
                print(f"| {name} | {h} | {mesher} | failed: {str(e)[:80]} |||||||||")
                rows.append({"input": name, "mesher": mesher, "error": str(e)})
                continue
            s.update(input=name, mesher=mesher, h=h, seconds=secs, diag=float(diag), sharp=sharp, chi_in=chi_in)
            rows.append(s)
            print(
                f"| {name} | {h} | {mesher} | {s['triangles']} | {s['min_angle']:.1f} | {s['max_angle']:.1f} | "
                f"{s['mean_q']:.4f} | {100 * s['size_dev']:.1f}% | {s['edge_over_h']:.3f} | {s['hausdorff']:.2e} | "
                f"{s['euler']} ({chi_in}) | {secs:.2f} |",
                flush=True,
            )
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
