#!/usr/bin/python3
"""Measurements of the distributed pipeline (digilap-mpi-spectrum, issue 24), printed as the
Markdown tables of docs/distributed.md.

usage: bench/mpi_measure.py BUILD_DIR {solvers,accuracy,memory,weak} [--data DIR] [--work DIR]

solvers  each eigen-solver (krylov-schur, lobpcg, lobpcg-amg, shift-invert) on 1 and 2 ranks
         against the one-machine digilap-spectrum, on the unit sphere at h = 0.05 and on the
         largest label of each atlas: seconds (cold: a fresh process each), iterations, peak
         memory per rank, the largest relative difference of the eigenvalues from the serial ones.
accuracy the default solver on P = 1, 2, 4 against digilap-spectrum, on the sphere at h = 0.025
         and the largest JHU 1 mm label (issue 24: within 1e-8 relative).
memory   one problem (the sphere at h = 0.025) on P = 1, 2, 4 ranks: memory per rank.
weak     a sphere at h = 0.05 whose surfel count grows with P (radius sqrt(P)), P = 1, 2, 4.

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
    t = re.search(r"operator ([\d.]+) s, eigenpairs ([\d.]+) s \(\S+, (\d+) iterations.*per rank (\d+) MiB \((\d+) MiB after", stdout)
    return dict(N=int(m[1]), nnz=int(m[2]), operator=float(t[1]), eigen=float(t[2]), iterations=int(t[3]), peak=int(t[4]),
                after_operator=int(t[5]), wall=wall, values=eigenvalues(os.path.join(out, "eigenvalues.csv")))


def serial_run(build, volume_args, out, count=10):
    stdout, wall = run([f"{build}/apps/digilap-spectrum", *volume_args, "--count", str(count), "--quiet",
                        "--out", out])
    return dict(wall=wall, values=eigenvalues(os.path.join(out, "eigenvalues.csv")))


def cases(args):
    yield "unit sphere, h = 0.05", ["--volume", sphere_volume(os.path.join(args.work, "sphere_0.05.npy"), 0.05), "--h", "0.05"]
    for atlas in ("JHU-WhiteMatter-labels-1mm.nii.gz", "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz"):
        path = os.path.join(args.data, atlas)
        label = largest_label(path)
        yield f"{atlas.split('-')[0]} 1 mm, label {label}", ["--volume", path, "--label", str(label)]


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
                rel = np.max(np.abs(r["values"][1:] - serial["values"][1:]) / np.abs(serial["values"][1:]))
                print(f"| {name} | {r['N']} | {r['nnz']} | {serial['wall']:.2f} | {ranks} | {solver} | {r['operator']:.2f} | "
                      f"{r['eigen']:.2f} | {r['wall']:.2f} | {r['iterations']} | {r['peak']} | {rel:.1e} |", flush=True)


def accuracy(args):
    """The sphere at h = 0.025 and a real label on P = 1, 2, 4 against the serial solver."""
    print("| case | N | P | serial s (cold) | mpi s (cold) | operator s | eigen s | peak MiB/rank | max rel. diff |")
    print("|---|---|---|---|---|---|---|---|---|")
    jhu = os.path.join(args.data, "JHU-WhiteMatter-labels-1mm.nii.gz")
    for name, volume_args in (
            ("unit sphere, h = 0.025", ["--volume", sphere_volume(os.path.join(args.work, "sphere_0.025.npy"), 0.025), "--h", "0.025"]),
            (f"JHU 1 mm, label {largest_label(jhu)}", ["--volume", jhu, "--label", str(largest_label(jhu))])):
        serial = serial_run(args.build, volume_args, os.path.join(args.work, "serial"))
        for ranks in (1, 2, 4):
            r = mpi_run(args.build, ranks, volume_args, os.path.join(args.work, "mpi"))
            rel = np.max(np.abs(r["values"][1:] - serial["values"][1:]) / np.abs(serial["values"][1:]))
            print(f"| {name} | {r['N']} | {ranks} | {serial['wall']:.2f} | {r['wall']:.2f} | {r['operator']:.2f} | {r['eigen']:.2f} | "
                  f"{r['peak']} | {rel:.1e} |", flush=True)


def memory(args):
    volume_args = ["--volume", sphere_volume(os.path.join(args.work, "sphere_0.025.npy"), 0.025), "--h", "0.025"]
    print("| P | N | nnz(L) | operator s | eigen s | peak MiB/rank | MiB/rank after the operator |")
    print("|---|---|---|---|---|---|---|")
    for ranks in (1, 2, 4):
        r = mpi_run(args.build, ranks, volume_args, os.path.join(args.work, "mpi"))
        print(f"| {ranks} | {r['N']} | {r['nnz']} | {r['operator']:.2f} | {r['eigen']:.2f} | {r['peak']} | {r['after_operator']} |", flush=True)


def weak(args):
    print("| P | radius | N | N/P | nnz(L) | operator s | eigen s | peak MiB/rank | MiB/rank after the operator |")
    print("|---|---|---|---|---|---|---|---|---|")
    for ranks in (1, 2, 4):
        radius = np.sqrt(ranks)
        path = sphere_volume(os.path.join(args.work, f"sphere_r{ranks}.npy"), 0.05, radius)
        r = mpi_run(args.build, ranks, ["--volume", path, "--h", "0.05"], os.path.join(args.work, "mpi"))
        print(f"| {ranks} | {radius:.3f} | {r['N']} | {r['N'] // ranks} | {r['nnz']} | {r['operator']:.2f} | {r['eigen']:.2f} | "
              f"{r['peak']} | {r['after_operator']} |", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("what", choices=["solvers", "accuracy", "memory", "weak"])
    parser.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "../../shared/data"))
    parser.add_argument("--work", default="/tmp/digilap_mpi_measure")
    args = parser.parse_args()
    os.makedirs(args.work, exist_ok=True)
    {"solvers": solvers, "accuracy": accuracy, "memory": memory, "weak": weak}[args.what](args)
