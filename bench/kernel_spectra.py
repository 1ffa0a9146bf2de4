#!/usr/bin/env python3
"""The surface kernels' spectra against exact ones (issue 23): chord (SPEC §7) and intrinsic (the
default), the library's default pipeline (Gauss digitization, II normals, measured l), worst and
median relative error of the first count-1 nonzero Laplace-Beltrami estimates.

Exact spectra: sphere l(l+1) (surface.sphere_spectrum), torus R = 1 and any r by separation of
variables (surface.torus_spectrum). With --fem, the mesh pipeline of tests/reference/mesh_fem.py
(marching cubes, cotan FEM, Taubin 10 and 50) on the same voxels, as the thin-tube table of
docs/accuracy.md. --matrix-free solves from products (what reaches h = 0.0125 on the sphere).

  PYTHONPATH=build/python /usr/bin/python3 bench/kernel_spectra.py --shape torus --h 0.05 0.025 0.0175
  PYTHONPATH=build/python /usr/bin/python3 bench/kernel_spectra.py --shape sphere --h 0.0125 --matrix-free --kernels intrinsic
  PYTHONPATH=build/python /usr/bin/python3 bench/kernel_spectra.py --shape torus --r 0.15 --h 0.075 0.05 0.0375 --fem
"""
import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests" / "reference"))
import digilap.surface as s  # noqa: E402

CENTRE = (0.0123, -0.0371, 0.0217)  # off the lattice, as SPEC §7's reference surfaces


def errors(values, exact):
    e = np.abs(np.asarray(values)[1:len(exact)] / exact[1:len(values)] - 1)
    return e.max(), np.median(e)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shape", choices=["sphere", "torus"], default="torus")
    parser.add_argument("--r", type=float, default=0.4, help="the torus's tube radius (R = 1)")
    parser.add_argument("--h", type=float, nargs="+", default=[0.05])
    parser.add_argument("--count", type=int, default=20)
    parser.add_argument("--kernels", nargs="+", default=["chord", "intrinsic"])
    parser.add_argument("--matrix-free", action="store_true")
    parser.add_argument("--fem", action="store_true", help="also the mesh pipeline (Taubin 10 and 50)")
    args = parser.parse_args()
    if args.shape == "torus":
        exact = np.asarray(s.torus_spectrum(1.0, args.r, args.count))
        surface = s.make_surface("torus:R=1,r=%g" % args.r)
    else:
        exact = np.asarray(s.sphere_spectrum(1.0, args.count))
        surface = s.make_surface("sphere")
    surface.set_pose(list(CENTRE), np.eye(3))
    print("| surface | h | N | method | worst | median | seconds |")
    print("|---|---|---|---|---|---|---|")
    name = args.shape if args.shape == "sphere" else "torus r = %g" % args.r
    for h in args.h:
        voxels = s.digitize(surface, h)
        surfels = s.extract_surfels(voxels)
        mu = s.measures(surfels, s.ii_normals(voxels, surfels))
        for kernel in args.kernels:
            start = time.time()
            if args.matrix_free:
                spectrum = s.MatrixFreeSurfaceOperator(surfels, mu, kernel=kernel).smallest_eigenpairs(args.count)
            else:
                spectrum = s.smallest_eigenpairs(s.heat_laplacian(surfels, mu, kernel=kernel), args.count)
            worst, median = errors(spectrum.laplace_beltrami, exact)
            print("| %s | %g | %d | %s | %.2f%% | %.2f%% | %.1f |" % (name, h, len(surfels), kernel, 100 * worst, 100 * median,
                                                                 time.time() - start), flush=True)
        if args.fem:
            import mesh_fem
            r = args.r
            c = CENTRE
            if args.shape == "torus":
                inside = lambda x, y, z: (np.hypot(x - c[0], y - c[1]) - 1.0) ** 2 + (z - c[2]) ** 2 < r * r  # noqa: E731
                box = (-1.1 - r, 1.1 + r)
            else:
                inside = lambda x, y, z: (x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2 < 1  # noqa: E731
                box = (-1.1, 1.1)
            mask = mesh_fem.gauss_digitization(inside, h, box)
            for smoothing in (10, 50):
                start = time.time()
                fem = mesh_fem.shape_dna(mask, h, args.count, smoothing)
                worst, median = errors(fem["eigenvalues"], exact)
                print("| %s | %g | %d | mesh FEM, Taubin %d | %.2f%% | %.2f%% | %.1f |" % (name, h, fem["vertices"], smoothing, 100 * worst,
                                                                                      100 * median, time.time() - start), flush=True)


if __name__ == "__main__":
    main()
