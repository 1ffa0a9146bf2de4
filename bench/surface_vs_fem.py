#!/usr/bin/env python3
"""digilap's surface spectrum against the mesh pipeline (marching cubes + cotan FEM + shift-invert
eigsh, tests/reference/mesh_fem.py), whole fresh processes on the same volume file (issue 23).

For each case the shape is Gauss-digitized here and saved as a .npy; then, each in a fresh
process timed by /usr/bin/time (wall clock, peak resident memory):
  digilap:  digilap-spectrum --volume case.npy --h H --count C
  mesh FEM: python3 -c "mesh_fem.shape_dna(...)"  (Taubin 10 iterations, as the issue's table)
and both spectra are compared with the exact one (sphere l(l+1); torus by separation of
variables, mesh_fem.torus_spectrum). Prints a Markdown table with the ratios.

  /usr/bin/python3 bench/surface_vs_fem.py --app build/apps/digilap-spectrum [--cases torus:0.05,sphere:0.025]
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

C = (0.0123, -0.0371, 0.0217)  # centres off the lattice, as SPEC §7's reference surfaces
SHAPES = {
    "sphere": (lambda x, y, z: (x - C[0]) ** 2 + (y - C[1]) ** 2 + (z - C[2]) ** 2 < 1.0, 1.1),
    "torus": (lambda x, y, z: (np.hypot(x - C[0], y - C[1]) - 1.0) ** 2 + (z - C[2]) ** 2 < 0.16, 1.5),
}


def timed(command, env):
    """(stdout, wall seconds, peak MB) of a fresh process under /usr/bin/time -v, with `env`."""
    run = subprocess.run(["/usr/bin/time", "-v"] + command, capture_output=True, text=True, env=env)
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", run.stderr)
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", run.stderr)
    seconds = 0.0
    for part in wall.group(1).split(":"):
        seconds = 60 * seconds + float(part)
    return run, seconds, int(peak.group(1)) / 1024.0


def worst(values, exact, count):
    k = min(len(values), count)
    return np.max(np.abs(np.asarray(values[1:k]) / exact[1:k] - 1))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--app", default="build/apps/digilap-spectrum")
    parser.add_argument("--cases", default="torus:0.05,torus:0.025,sphere:0.05,sphere:0.025",
                        help="shape:h pairs (shapes: sphere, torus R = 1, r = 0.4)")
    parser.add_argument("--count", type=int, default=20)
    parser.add_argument("--smoothing", type=int, default=10)
    parser.add_argument("--threads", default="2")
    parser.add_argument("--variants", default="assembled,matrix-free",
                        help="digilap runs: assembled and/or matrix-free, each optionally @tolerance (matrix-free@1e-8) "
                             "and :key=value or :flag options of digilap-spectrum (matrix-free:ct=0.05 passes --ct 0.05)")
    args = parser.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS=args.threads, OPENBLAS_NUM_THREADS=args.threads)
    work = pathlib.Path(tempfile.mkdtemp(prefix="surface_vs_fem_"))
    rows = []
    for case in args.cases.split(","):
        shape, h = case.split(":")
        h = float(h)
        inside, extent = SHAPES[shape]
        mask = mesh_fem.gauss_digitization(inside, h, (-extent, extent))
        path = work / ("%s_%g.npy" % (shape, h))
        np.save(path, mask.astype(np.uint8))
        exact = mesh_fem.sphere_spectrum(args.count) if shape == "sphere" else mesh_fem.torus_spectrum(args.count)
        print("surface_vs_fem: %s h = %g (%d voxels inside)" % (shape, h, mask.sum()), file=sys.stderr, flush=True)

        digilap_runs = []
        for variant in args.variants.split(","):
            out = work / ("out_%s_%g_%s" % (shape, h, re.sub(r"[@:=]", "_", variant)))
            head, *options = variant.split(":")  # matrix-free:ct=0.05: with --ct 0.05
            kind, _, tolerance = head.partition("@")  # matrix-free@1e-8: with --tolerance 1e-8
            flags = ["--matrix-free"] if kind == "matrix-free" else []
            flags += ["--tolerance", tolerance] if tolerance else []
            for option in options:  # key=value, or a flag alone (matrix-free:one-heat-time)
                key, equals, value = option.partition("=")
                flags += ["--" + key] + ([value] if equals else [])
            run, d_wall, d_peak = timed([args.app, "--volume", str(path), "--h", str(h), "--count", str(args.count), "--draw", "0",
                                         "--quiet", "--out", str(out)] + flags, env)
            if run.returncode == 0:
                table = np.genfromtxt(out / "eigenvalues.csv", delimiter=",", names=True)
                ours = np.sort(table["laplace_beltrami"])
                surfels = int(re.search(r"N = (\d+) surfels", run.stdout).group(1))
                d_error = "%.2f%%" % (100 * worst(ours, exact, args.count))
            else:
                surfels, d_error = 0, "refused: " + run.stderr.strip().splitlines()[-1][:80]
            digilap_runs.append((variant, surfels, d_wall, d_peak, d_error))
            subprocess.run(["rm", "-rf", str(out)])
        script = ("import sys, numpy as np; sys.path.insert(0, %r); import mesh_fem; "
                  "r = mesh_fem.shape_dna(np.load(%r).astype(bool), %r, %d, %d); "
                  "print(r['vertices'], *r['eigenvalues'])" % (str(REFERENCE), str(path), h, args.count, args.smoothing))
        run, f_wall, f_peak = timed(["/usr/bin/python3", "-c", script], env)
        fields = run.stdout.split()
        vertices, theirs = int(fields[0]), np.array([float(v) for v in fields[1:]])
        f_error = "%.2f%%" % (100 * worst(theirs, exact, args.count))
        for variant, surfels, d_wall, d_peak, d_error in digilap_runs:
            rows.append((shape, h, variant, surfels, vertices, d_wall, d_peak, f_wall, f_peak, d_error, f_error))
        subprocess.run(["rm", "-rf", str(path)])
    print("| case | digilap | N surfels / mesh vertices | digilap wall / peak | FEM (Taubin %d) wall / peak | wall ratio | "
          "memory ratio | digilap worst error | FEM worst error |" % args.smoothing)
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print("| %s h = %g, %d eigenpairs | %s | %d / %d | %.1f s / %.0f MB | %.1f s / %.0f MB | %.2f× | %.2f× | %s | %s |"
              % (r[0], r[1], args.count, r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[5] / r[7], r[6] / r[8], r[9], r[10]))


if __name__ == "__main__":
    main()
