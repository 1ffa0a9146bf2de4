#!/usr/bin/env python3
"""Surface spectra's accuracy against the II radius constant k_R (issue 23): the reference volumes
of bench/surface_vs_fem.py (Gauss digitization, centre off the lattice), digilap-spectrum with
--kR K (0: the default, k_R from l / h), and for each h: the estimated area's error, the worst and mean relative error of the first
count-1 nonzero Laplace-Beltrami estimates against the exact spectrum (sphere l(l+1), torus
R = 1, tube r (--r, 0.4 by default) by separation of variables), and the "normals" stage's time (from the app's own
timer, 2 threads). Prints a Markdown table (docs/accuracy.md).

  /usr/bin/python3 bench/ii_radius_study.py --shape torus --h 0.05 0.025 0.0175 0.0125 --kR 0 0.7 1 1.5 2
"""
import argparse
import os
import pathlib
import re
import subprocess
import sys
import tempfile

import numpy as np

REFERENCE = pathlib.Path(__file__).resolve().parents[1] / "tests" / "reference"
sys.path.insert(0, str(REFERENCE))
import mesh_fem  # noqa: E402

C = (0.0123, -0.0371, 0.0217)  # as bench/surface_vs_fem.py


def shape(name, r):
    """(inside, half extent, exact area) of the unit sphere or the torus R = 1, tube r."""
    if name == "sphere":
        return (lambda x, y, z: (x - C[0]) ** 2 + (y - C[1]) ** 2 + (z - C[2]) ** 2 < 1.0), 1.1, 4 * np.pi
    return ((lambda x, y, z: (np.hypot(x - C[0], y - C[1]) - 1.0) ** 2 + (z - C[2]) ** 2 < r * r), 1.1 + r,
            4 * np.pi ** 2 * r)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--app", default="build/apps/digilap-spectrum")
    parser.add_argument("--shape", choices=["sphere", "torus"], default="torus")
    parser.add_argument("--r", type=float, default=0.4, help="the torus's tube radius (R = 1)")
    parser.add_argument("--h", type=float, nargs="+", default=[0.05, 0.025])
    parser.add_argument("--kR", type=float, nargs="+", default=[0.0], help="0: the app's default")
    parser.add_argument("--count", type=int, default=20)
    parser.add_argument("--threads", default="2")
    args = parser.parse_args()
    inside, extent, area = shape(args.shape, args.r)
    exact = mesh_fem.sphere_spectrum(args.count) if args.shape == "sphere" else mesh_fem.torus_spectrum(args.count, r=args.r)
    env = dict(os.environ, OMP_NUM_THREADS=args.threads)
    work = pathlib.Path(tempfile.mkdtemp(prefix="ii_radius_"))
    print("| k_R | h | N | R | area error | worst error (mode) | mean error | normals stage |")
    print("|---|---|---|---|---|---|---|---|")
    for h in args.h:
        path = work / ("%s_%g.npy" % (args.shape, h))
        np.save(path, mesh_fem.gauss_digitization(inside, h, (-extent, extent)).astype(np.uint8))
        for k_r in args.kR:
            print("ii_radius_study: %s h = %g k_R = %g" % (args.shape, h, k_r), file=sys.stderr, flush=True)
            out = work / "out"
            radius = ["--kR", str(k_r)] if k_r > 0 else []
            run = subprocess.run([args.app, "--volume", str(path), "--h", str(h), "--count", str(args.count), *radius,
                                  "--draw", "0", "--out", str(out)], capture_output=True, text=True, env=env, check=True)
            table = np.genfromtxt(out / "eigenvalues.csv", delimiter=",", names=True)
            ours = np.sort(table["laplace_beltrami"])
            e = ours[1:args.count] / exact[1:args.count] - 1
            header = re.search(r"N = (\d+) surfels, area ([0-9.]+)", run.stdout)
            normals = re.search(r"normals\s+\.\.\.\s+([0-9.]+) s", run.stderr)
            ball = re.search(r"II radius R = ([0-9.e+-]+)", run.stderr)
            print("| %s | %g | %s | %s | %+.2f%% | %.2f%% (k = %d) | %+.2f%% | %s s |"
                  % ("%g" % k_r if k_r > 0 else "default", h, header.group(1), ball.group(1) if ball else "?",
                     100 * (float(header.group(2)) / area - 1), 100 * np.abs(e).max(),
                     1 + np.abs(e).argmax(), 100 * e.mean(), normals.group(1) if normals else "?"), flush=True)
        path.unlink()


if __name__ == "__main__":
    main()
