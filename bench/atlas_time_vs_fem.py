#!/usr/bin/env python3
"""A whole atlas's spectra, digilap against the mesh pipeline, as a user waits for them: each
method in a fresh process timed by /usr/bin/time (wall clock, peak resident memory).

  digilap:  digilap-spectrum --volume ATLAS --labels all --count C -q [--tolerance T]
  mesh FEM: one Python process doing, for every label, what BrainPrint / LaPy do: marching cubes
            of the label's voxels, Taubin 10 (tests/reference/mesh_fem.py), cotan FEM,
            eigsh(sigma=-0.01) for C eigenvalues; with --fem-processes 2 the labels are shared
            by two worker processes (a peer that also uses both cores; its peak is the largest
            process's, as /usr/bin/time reports it).

Both take every voxel of a label (all its components). Prints a Markdown table with the ratios
and how far the two methods' eigenvalues are apart (median over labels of the median relative
difference, ev1 to ev<C-1>), so that a faster run is seen to compute the same thing.

  /usr/bin/python3 bench/atlas_time_vs_fem.py ../shared/data/JHU-WhiteMatter-labels-1mm.nii.gz \\
      --app build/apps/digilap-spectrum --variants default,1e-6 --fem-processes 1,2
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

# The peer, run in its own process: every label of the volume, its C smallest eigenvalues.
FEM_SCRIPT = r"""
import sys, multiprocessing
import numpy as np, nibabel
sys.path.insert(0, %(reference)r)
import mesh_fem

SEG, H = None, 1.0


def one(label):
    # The label's bounding box only (marching cubes over the whole volume for each label
    # would be the peer's loss, not its method's).
    mask = SEG == label
    box = tuple(slice(a.min(), a.max() + 1) for a in np.nonzero(mask))
    vertices, faces = mesh_fem.marching_cubes(mask[box], H)
    if %(smoothing)d:
        vertices = mesh_fem.taubin(vertices, faces, %(smoothing)d)
    K, M = mesh_fem.fem_matrices(vertices, faces)
    count = min(%(count)d, len(vertices) - 2)
    return label, mesh_fem.smallest_eigenvalues(K, M, count)

if __name__ == "__main__":
    image = nibabel.load(%(volume)r)
    SEG, H = np.asarray(image.dataobj), float(image.header.get_zooms()[0])
    labels = [int(v) for v in np.unique(SEG) if v != 0]
    if %(processes)d > 1:  # forked workers inherit SEG
        with multiprocessing.Pool(%(processes)d) as pool:
            results = pool.map(one, labels, chunksize=1)
    else:
        results = [one(label) for label in labels]
    for label, values in results:
        print(label, *values)
"""


def timed(command, env):
    """(completed process, wall seconds, peak MB) of a fresh process under /usr/bin/time -v."""
    run = subprocess.run(["/usr/bin/time", "-v"] + command, capture_output=True, text=True, env=env)
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", run.stderr)
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", run.stderr)
    if run.returncode != 0 or not wall:
        sys.exit("atlas_time_vs_fem: %s failed:\n%s" % (command[0], run.stderr[-2000:]))
    seconds = 0.0
    for part in wall.group(1).split(":"):
        seconds = 60 * seconds + float(part)
    return run, seconds, int(peak.group(1)) / 1024.0


def read_digilap(path, count):
    """label -> eigenvalue estimates (Laplace-Beltrami) from a spectra.csv (one column a label)."""
    rows = {}
    with open(path) as f:
        for line in f:
            fields = line.rstrip("\n").split(",")
            rows[fields[0]] = fields[1:]
    labels = [int(v) for v in rows["label"]]
    values = np.array([[float(v) for v in rows["ev%d" % k]] for k in range(count)])
    return {label: values[:, n] for n, label in enumerate(labels)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("volume")
    parser.add_argument("--app", default="build/apps/digilap-spectrum")
    parser.add_argument("--count", type=int, default=50)
    parser.add_argument("--smoothing", type=int, default=10)
    parser.add_argument("--threads", default="2")
    parser.add_argument("--variants", default="default",
                        help="digilap runs: default and/or a tolerance (1e-6), and/or matrix-free[@tolerance]")
    parser.add_argument("--fem-processes", default="1", help="comma-separated: 1 (BrainPrint's loop) and/or 2")
    args = parser.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS=args.threads, OPENBLAS_NUM_THREADS="1")
    work = pathlib.Path(tempfile.mkdtemp(prefix="atlas_time_vs_fem_"))

    fem_runs = []
    for processes in [int(p) for p in args.fem_processes.split(",")]:
        print("atlas_time_vs_fem: mesh FEM, %d process(es)" % processes, file=sys.stderr, flush=True)
        script = FEM_SCRIPT % {"reference": str(REFERENCE), "volume": os.path.abspath(args.volume), "count": args.count,
                               "smoothing": args.smoothing, "processes": processes}
        run, wall, peak = timed(["/usr/bin/python3", "-c", script], env)
        fem = {}
        for line in run.stdout.split("\n"):
            if line.strip():
                fields = line.split()
                fem[int(fields[0])] = np.array([float(v) for v in fields[1:]])
        fem_runs.append((processes, wall, peak, fem))

    rows = []
    for variant in args.variants.split(","):
        print("atlas_time_vs_fem: digilap %s" % variant, file=sys.stderr, flush=True)
        kind, _, tolerance = variant.partition("@")
        if kind not in ("default", "matrix-free"):
            kind, tolerance = "default", variant
        out = work / ("out_" + variant.replace("@", "_"))
        flags = ["--matrix-free"] if kind == "matrix-free" else []
        flags += ["--tolerance", tolerance] if tolerance else []
        run, wall, peak = timed([args.app, "--volume", args.volume, "--labels", "all", "--count", str(args.count), "-q",
                                 "--out", str(out)] + flags, env)
        ours = read_digilap(out / "spectra.csv", args.count)
        failed = sum(1 for line in open(out / "spectra_log.csv") if ",failed," in line)
        gaps = []
        for label, theirs in fem_runs[0][3].items():
            k = min(len(theirs), args.count)
            rel = ours[label][1:k] / theirs[1:k] - 1
            rel = rel[np.isfinite(rel)]
            if len(rel):
                gaps.append(np.median(rel))
        rows.append((variant, wall, peak, failed, np.median(gaps) if gaps else np.nan))
        subprocess.run(["rm", "-rf", str(out)])

    name = pathlib.Path(args.volume).name
    print("| atlas | digilap | digilap wall / peak | labels failed | mesh FEM (Taubin %d) | FEM wall / peak | wall ratio | "
          "memory ratio | λ digilap / FEM − 1 (median) |" % args.smoothing)
    print("|---|---|---|---|---|---|---|---|---|")
    for variant, wall, peak, failed, gap in rows:
        for processes, f_wall, f_peak, _ in fem_runs:
            print("| %s, %d eigenvalues | %s | %.1f s / %.0f MB | %d | %d process%s | %.1f s / %.0f MB | %.2f× | %.2f× | %+.1f%% |"
                  % (name, args.count, variant, wall, peak, failed, processes, "es" if processes > 1 else "", f_wall, f_peak,
                     wall / f_wall, peak / f_peak, 100 * gap))
    subprocess.run(["rm", "-rf", str(work)])


if __name__ == "__main__":
    main()
