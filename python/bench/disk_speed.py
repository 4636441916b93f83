"""The unit disk at h0 = 0.01 three ways, interleaved: the command line as a whole process
(writing a binary .vtu), numpy callables through `distmesh2d`, and an expression string
through `mesh_2d`. Prints the medians and the ratios to the command line.

    python python/bench/disk_speed.py [path/to/trussmesh] [runs]

The binary defaults to target/release/trussmesh (build it with `cargo build --release`).
"""

import statistics
import subprocess
import sys
import tempfile
import time

import trussmesh as tm

binary = sys.argv[1] if len(sys.argv) > 1 else "target/release/trussmesh"
runs = int(sys.argv[2]) if len(sys.argv) > 2 else 5
out = tempfile.mkdtemp() + "/disk.vtu"
cli = [binary, "mesh", "--dim", "2", "--domain", "sqrt(x^2+y^2)-1", "--h0", "0.01", "--bbox", "-1,-1,1,1",
       "-o", out, "--encoding", "binary"]
T = {"command line": [], "numpy": [], "expression": []}
for _ in range(runs):
    t = time.perf_counter()
    subprocess.run(cli, check=True, capture_output=True)
    T["command line"].append(time.perf_counter() - t)
    t = time.perf_counter()
    p, _t = tm.distmesh2d(lambda q: tm.dcircle(q, 0, 0, 1), tm.huniform, 0.01, [[-1, -1], [1, 1]])
    T["numpy"].append(time.perf_counter() - t)
    t = time.perf_counter()
    tm.mesh_2d("sqrt(x^2+y^2)-1", (-1, -1, 1, 1), 0.01)
    T["expression"].append(time.perf_counter() - t)
med = {k: statistics.median(v) for k, v in T.items()}
base = med["command line"]
for k, v in med.items():
    print(f"{k}: median {v:.3f} s ({v / base:.2f}x the command line), runs {[round(x, 3) for x in T[k]]}")
print(f"{len(p)} nodes")
