#!/usr/bin/python3
"""Measurements of the distributed pipeline (digilap-mpi-spectrum, issue 24), printed as the
Markdown tables of docs/benchmarks.md ("Beyond one machine").

usage: bench/mpi_measure.py BUILD_DIR {solvers,accuracy,memory,weak,atlas} [--data DIR] [--work DIR]

solvers  each eigen-solver (krylov-schur, lobpcg, lobpcg-amg, shift-invert) on 1 and 2 ranks
         against the one-machine digilap-spectrum, on the unit sphere at h = 0.05 and on the
         largest label of each atlas: seconds (cold: a fresh process each), iterations, peak
         memory per rank, the largest relative difference of the eigenvalues from the serial ones.
accuracy the default solver on P = 1, 2, 4 against digilap-spectrum, on the sphere at h = 0.025
         and the largest JHU 1 mm label (issue 24: within 1e-8 relative).
memory   one problem (the sphere at h = 0.025) on P = 1, 2, 4 ranks: memory per rank.
atlas    every label of each atlas in --data (--largest), on 2 ranks against digilap-spectrum:
         the largest relative difference of the 10 smallest eigenvalues, label by label.
weak     a sphere at h = 0.05 whose surfel count grows with P (radius sqrt(P), t held), P = 1, 2, 4.

Every run is a fresh process (mpirun), so every time is what a user waits for. This machine has
2 cores: P = 4 is oversubscribed, and its times say nothing about a cluster; its memory does.
"""
import argparse
import csv
import os
import re
import subprocess
import sys
import time

import numpy as np

ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_NUM_THREADS="1")


def sphere_volume(path, h, radius=1.0):
    """Gauss digitization of the ball of `radius` at step h: voxel (i, j, k) is inside when its
    centre ((i, j, k) + 1/2 - n/2) h is; saved as uint8 .npy."""
    if os.path.exists(path):
        return path
    n = int(np.ceil(2 * radius / h)) + 4
    c = (np.arange(n) + 0.5 - n / 2) * h
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    np.save(path, (x * x + y * y + z * z <= radius * radius).astype(np.uint8))
    return path


def largest_label(path):
    """The label with the most voxels (nibabel)."""
    import nibabel

    data = np.asarray(nibabel.load(path).dataobj).astype(np.int64)
    counts = np.bincount(data.ravel())
    counts[0] = 0
    return int(counts.argmax())


def relative_difference(got, want):
    """Largest |got - want| relative to |want|, over the nonzero eigenvalues (one 0 per surface,
    exact on both sides up to rounding, is left out)."""
    nonzero = np.abs(want) > 1e-12 * np.abs(want).max()
    return np.max(np.abs(got[nonzero] - want[nonzero]) / np.abs(want[nonzero])) if nonzero.any() else float("nan")


def eigenvalues(path):
    with open(path) as f:
        return np.array([float(r["lambda"]) for r in csv.DictReader(f)])


TIMEOUT = 300  # seconds; a slower run is reported as "> 300 s"


def run(args):
    t0 = time.perf_counter()
    try:
        done = subprocess.run(args, env=ENV, capture_output=True, text=True, timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        return None, TIMEOUT
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(f"{' '.join(args)}: exit {done.returncode}\n{done.stdout}\n{done.stderr}")
    return done.stdout, seconds


SOLVERS = ("krylov-schur", "lobpcg", "lobpcg-amg", "shift-invert")


def mpi_run(build, ranks, volume_args, out, solver="krylov-schur", count=10, tol=1e-10):
    stdout, wall = run(["mpirun", "--oversubscribe", "-n", str(ranks), f"{build}/apps/digilap-mpi-spectrum", *volume_args,
                        "--count", str(count), "--solver", solver, "--tol", str(tol), "--quiet", "--out", out])
    if stdout is None:
        return None
    m = re.search(r"N = (\d+) surfels.*nnz\(L\) = (\d+)", stdout)
    heat_time = float(re.search(r", t = ([\d.e+-]+);", stdout)[1])
    t = re.search(r"operator ([\d.]+) s, eigenpairs ([\d.]+) s \(\S+, (\d+) iterations.*per rank (\d+) MiB \((\d+) MiB after", stdout)
    return dict(N=int(m[1]), nnz=int(m[2]), t=heat_time, operator=float(t[1]), eigen=float(t[2]), iterations=int(t[3]), peak=int(t[4]),
                after_operator=int(t[5]), wall=wall, values=eigenvalues(os.path.join(out, "eigenvalues.csv")))


def serial_run(build, volume_args, out, count=10):
    stdout, wall = run([f"{build}/apps/digilap-spectrum", *volume_args, "--count", str(count), "--quiet",
                        "--out", out])
    return dict(wall=wall, values=eigenvalues(os.path.join(out, "eigenvalues.csv")))


def cases(args):
    for name, volume_args in all_cases(args):
        if not args.cases or any(c in name for c in args.cases.split(",")):
            yield name, volume_args


def all_cases(args):
    yield "unit sphere, h = 0.05", ["--volume", sphere_volume(os.path.join(args.work, "sphere_0.05.npy"), 0.05), "--h", "0.05"]
    for atlas in ("JHU-WhiteMatter-labels-1mm.nii.gz", "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz"):
        path = os.path.join(args.data, atlas)
        label = largest_label(path)
        yield f"{atlas.split('-')[0]} 1 mm, label {label} (--largest)", ["--volume", path, "--label", str(label), "--largest"]


def solvers(args):
    print("| case | N | nnz(L) | serial s | P | solver | operator s | eigen s | total s (cold) | iterations | peak MiB/rank | max rel. diff |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, volume_args in cases(args):
        serial = serial_run(args.build, volume_args, os.path.join(args.work, "serial"))
        for ranks in (1, 2):
            for solver in SOLVERS:
                r = mpi_run(args.build, ranks, volume_args, os.path.join(args.work, "mpi"), solver)
                if r is None:
                    print(f"| {name} | | | {serial['wall']:.2f} | {ranks} | {solver} | | | > {TIMEOUT} | | | |", flush=True)
                    continue
                rel = relative_difference(r["values"], serial["values"])
                print(f"| {name} | {r['N']} | {r['nnz']} | {serial['wall']:.2f} | {ranks} | {solver} | {r['operator']:.2f} | "
                      f"{r['eigen']:.2f} | {r['wall']:.2f} | {r['iterations']} | {r['peak']} | {rel:.1e} |", flush=True)


def accuracy(args):
    """The sphere at h = 0.025 and a real label on P = 1, 2, 4 against the serial solver."""
    print("| case | N | P | serial s (cold) | mpi s (cold) | operator s | eigen s | peak MiB/rank | max rel. diff |")
    print("|---|---|---|---|---|---|---|---|---|")
    jhu = os.path.join(args.data, "JHU-WhiteMatter-labels-1mm.nii.gz")
    for name, volume_args in (
            ("unit sphere, h = 0.025", ["--volume", sphere_volume(os.path.join(args.work, "sphere_0.025.npy"), 0.025), "--h", "0.025"]),
            (f"JHU 1 mm, label {largest_label(jhu)} (--largest)", ["--volume", jhu, "--label", str(largest_label(jhu)), "--largest"])):
        serial = serial_run(args.build, volume_args, os.path.join(args.work, "serial"))
        for ranks in (1, 2, 4):
            r = mpi_run(args.build, ranks, volume_args, os.path.join(args.work, "mpi"))
            rel = relative_difference(r["values"], serial["values"])
            print(f"| {name} | {r['N']} | {ranks} | {serial['wall']:.2f} | {r['wall']:.2f} | {r['operator']:.2f} | {r['eigen']:.2f} | "
                  f"{r['peak']} | {rel:.1e} |", flush=True)


def memory(args):
    volume_args = ["--volume", sphere_volume(os.path.join(args.work, "sphere_0.025.npy"), 0.025), "--h", "0.025"]
    print("| P | N | nnz(L) | operator s | eigen s | peak MiB/rank | MiB/rank after the operator |")
    print("|---|---|---|---|---|---|---|")
    for ranks in (1, 2, 4):
        r = mpi_run(args.build, ranks, volume_args, os.path.join(args.work, "mpi"))
        print(f"| {ranks} | {r['N']} | {r['nnz']} | {r['operator']:.2f} | {r['eigen']:.2f} | {r['peak']} | {r['after_operator']} |", flush=True)


def atlas(args):
    print("| atlas | labels | N (sum) | serial s (sum, cold) | P = 2 s (sum, cold) | worst max rel. diff (label) | failures |")
    print("|---|---|---|---|---|---|---|")
    import nibabel

    for atlas in sorted(f for f in os.listdir(args.data) if f.endswith((".nii", ".nii.gz"))):
        path = os.path.join(args.data, atlas)
        labels = [int(v) for v in np.unique(np.asarray(nibabel.load(path).dataobj)) if v > 0]
        n = serial_s = mpi_s = 0
        worst, worst_label, failures = 0.0, None, []
        for i, label in enumerate(labels):
            print(f"\r{atlas}: label {label} ({i + 1}/{len(labels)})", end="", file=sys.stderr, flush=True)
            volume_args = ["--volume", path, "--label", str(label), "--largest"]
            try:
                serial = serial_run(args.build, volume_args, os.path.join(args.work, "serial"))
                r = mpi_run(args.build, 2, volume_args, os.path.join(args.work, "mpi"))
            except SystemExit as e:  # a run that exits nonzero: reported, the others go on
                print(f"\nlabel {label}: {str(e)[-300:]}", file=sys.stderr)
                failures.append(label)
                continue
            if r is None or len(r["values"]) != len(serial["values"]):
                failures.append(label)
                continue
            rel = relative_difference(r["values"], serial["values"])
            n, serial_s, mpi_s = n + r["N"], serial_s + serial["wall"], mpi_s + r["wall"]
            if rel > worst:
                worst, worst_label = rel, label
        print(file=sys.stderr)
        print(f"| {atlas} | {len(labels)} | {n} | {serial_s:.1f} | {mpi_s:.1f} | {worst:.1e} ({worst_label}) | "
              f"{', '.join(map(str, failures)) or 'none'} |", flush=True)


def weak(args):
    """Radius sqrt(P) at h = 0.05: N grows as P. The heat time is held at the P = 1 one (--t), so
    the kernel covers the same voxels and the nonzeros per row stay the same: work per rank is
    constant, as in a weak-scaling test; with t from each sphere's own l they would grow as l^(4/3)."""
    print("| P | radius | N | N/P | nnz(L) | nnz/row | operator s | eigen s | iterations | peak MiB/rank | MiB/rank after the operator |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    t = None
    for ranks in (1, 2, 4):
        radius = np.sqrt(ranks)
        path = sphere_volume(os.path.join(args.work, f"sphere_r{ranks}.npy"), 0.05, radius)
        extra = ["--t", repr(t)] if t else []
        r = mpi_run(args.build, ranks, ["--volume", path, "--h", "0.05", *extra], os.path.join(args.work, "mpi"))
        t = t or r["t"]
        print(f"| {ranks} | {radius:.3f} | {r['N']} | {r['N'] // ranks} | {r['nnz']} | {r['nnz'] / r['N']:.0f} | {r['operator']:.2f} | "
              f"{r['eigen']:.2f} | {r['iterations']} | {r['peak']} | {r['after_operator']} |", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("what", choices=["solvers", "accuracy", "memory", "weak", "atlas"])
    parser.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "../../shared/data"))
    parser.add_argument("--work", default="/tmp/digilap_mpi_measure")
    parser.add_argument("--cases", default="", help="solvers: only the cases whose name contains one of these (comma-separated: sphere,JHU)")
    args = parser.parse_args()
    os.makedirs(args.work, exist_ok=True)
    {"solvers": solvers, "accuracy": accuracy, "memory": memory, "weak": weak, "atlas": atlas}[args.what](args)
