"""The seed's 2-D examples three ways, measured alike: the command line (`trussmesh mesh` with the
arguments `trussmesh gallery --list` prints), Python with numpy callables (examples/
seed_chapter2.py through `mesh_2d`, what `distmesh2d` calls) and Python with the command line's
expression strings. Every mesh is written to .vtu and measured by `trussmesh stats` with the
example's domain and size, so the figures come from one tool.

    python examples/compare_cli.py --cli target/release/trussmesh [NAME ...]

Then the unit disk at h0 = 0.01 for speed: the command line's wall time against the Python
call's, with numpy callables and with an expression string (median of --repeat runs each,
interleaved).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import subprocess
import sys
import tempfile
import time

import numpy as np

import trussmesh as tm

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import seed_chapter2 as seed  # noqa: E402


def constant(s: str) -> float:
    return float(eval(s, {"__builtins__": {}}, {"pi": math.pi, "sqrt": math.sqrt}))


def gallery(cli: str):
    out = subprocess.run([cli, "gallery", "--list"], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        words = shlex.split(line)[1:]
        args = {}
        i = 0
        while i < len(words):
            w = words[i]
            if w == "--implicit":
                args["implicit"] = True
                i += 1
            elif w.startswith("--") or w == "-o":
                args.setdefault(w, []).append(words[i + 1])
                i += 2
            else:
                args.setdefault("cmd", []).append(w)
                i += 1
        name = os.path.splitext(os.path.basename(args["-o"][0]))[0]
        yield name, words, args


def stats(cli: str, path: str, args: dict) -> dict:
    cmd = [cli, "stats", "--json", path, "--domain", args["--domain"][0]]
    cmd += ["--size", args.get("--size", ["1"])[0]]
    if args.get("implicit"):
        cmd.append("--implicit")
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)


def cli_args(words, out):
    a = [w for w in words]
    # Replace the outputs.
    keep = []
    i = 0
    while i < len(a):
        if a[i] == "-o":
            i += 2
            continue
        keep.append(a[i])
        i += 1
    return keep + ["-o", out, "-q"]


def expr_mesh(args: dict) -> tm.Mesh:
    b = [constant(v) for v in args["--bbox"][0].split(",")]
    fix = None
    if "--fix" in args:
        fix = [[constant(c) for c in p.split(",")] for p in args["--fix"][0].split(";") if p.strip()]
    return tm.mesh_2d(
        args["--domain"][0],
        b,
        constant(args["--h0"][0]),
        size=args.get("--size", [None])[0],
        fixed=fix,
        implicit=bool(args.get("implicit")),
        internal=args.get("--internal", [None])[0],
        metric=args.get("--metric", [None])[0],
    )


def row(name, how, s, secs, extra=""):
    t = s.get("triangles") or {}
    h0 = s.get("_h0", 1.0)
    dev = s.get("size_deviation")
    bd = s.get("boundary_max_abs_d")
    return (
        f"| {name} | {how} | {s['nodes']} | {s['cells']} | {t.get('q_min', float('nan')):.3f} | "
        f"{t.get('q_mean', float('nan')):.3f} | {t.get('angle_min', float('nan')):.1f} | "
        f"{dev if dev is None else f'{dev:.3f}'} | {bd if bd is None else f'{bd / h0:.1e}'} | {secs:.2f} | {extra} |"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", default="trussmesh", help="the trussmesh binary")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each speed measurement")
    ap.add_argument("--no-speed", action="store_true")
    ap.add_argument("names", nargs="*")
    a = ap.parse_args(argv)
    tmp = tempfile.mkdtemp(prefix="trussmesh-compare-")
    print("| example | run | nodes | triangles | q min | q mean | min angle | size dev | max \\|d\\|/h0 | seconds | notes |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, words, args in gallery(a.cli):
        if a.names and name not in a.names:
            continue
        h0 = constant(args["--h0"][0])
        out = os.path.join(tmp, f"{name}-cli.vtu")
        t0 = time.perf_counter()
        subprocess.run([a.cli] + cli_args(words, out), check=True)
        secs = time.perf_counter() - t0
        s = stats(a.cli, out, args)
        s["_h0"] = h0
        print(row(name, "command line", s, secs))
        for how in ("numpy", "expression"):
            t0 = time.perf_counter()
            m = seed.run(name) if how == "numpy" else expr_mesh(args)
            secs = time.perf_counter() - t0
            path = os.path.join(tmp, f"{name}-{how}.vtu")
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # meshio pads 2-D points for VTU
                m.to_meshio().write(path, binary=False)  # the command line reads uncompressed VTU
            s = stats(a.cli, path, args)
            s["_h0"] = h0
            notes = ""
            if m.report.get("metric"):
                mm = m.report["metric"]
                notes = f"metric q min {mm['q_min']:.3f}, mean {mm['q_mean']:.3f}"
            print(row(name, f"python {how}", s, secs, notes))
    if a.no_speed:
        return 0
    fd = lambda p: np.sqrt((p**2).sum(axis=1)) - 1  # noqa: E731
    cli = [a.cli, "mesh", "--domain", "sqrt(x^2+y^2)-1", "--h0", "0.01", "--bbox", "-1,-1,1,1", "-o", os.path.join(tmp, "disk.json"), "-q"]
    times = {"command line": [], "python numpy": [], "python expression": []}
    for _ in range(a.repeat):
        t0 = time.perf_counter()
        subprocess.run(cli, check=True)
        times["command line"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        tm.mesh_2d(fd, [[-1, -1], [1, 1]], 0.01)
        times["python numpy"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        tm.mesh_2d("sqrt(x^2+y^2)-1", [[-1, -1], [1, 1]], 0.01)
        times["python expression"].append(time.perf_counter() - t0)
    base = float(np.median(times["command line"]))
    print()
    print("| unit disk, h0 = 0.01 | median wall s | ratio to the command line |")
    print("|---|---|---|")
    for k, v in times.items():
        med = float(np.median(v))
        print(f"| {k} | {med:.3f} | {med / base:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
