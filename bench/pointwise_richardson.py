#!/usr/bin/env python3
"""Richardson in t on the surface products (issue 23): the pointwise error of L_t g, L_{t/2} g and
2 L_{t/2} g - L_t g against the exact Laplace-Beltrami of g = x^2 on the unit sphere (SPEC §7,
closest-point sampling, centre off the lattice), for both surface kernels, matrix-free.

  PYTHONPATH=build/python /usr/bin/python3 bench/pointwise_richardson.py 0.1 0.05 0.035
"""
import sys

import numpy as np

import digilap.surface as s

CENTRE = [0.0123, -0.0371, 0.0217]


def main():
    sphere = s.make_surface("sphere")
    sphere.set_pose(CENTRE, np.eye(3))
    print("| h | kernel | L_t | L_t/2 | 2 L_t/2 - L_t |")
    print("|---|---|---|---|---|")
    for h in map(float, sys.argv[1:] or ["0.1", "0.05"]):
        voxels = s.digitize(sphere, h)
        surfels = s.extract_surfels(voxels)
        mu = s.measures(surfels, s.ii_normals(voxels, surfels))
        p = np.array([sphere.closest_point(x) for x in np.asarray(surfels.centres)])
        q = p - np.array(CENTRE)
        n = np.array([sphere.normal(x) for x in p])
        g = (q[:, 0] ** 2).reshape(-1, 1)
        exact = 2 - 2 * n[:, 0] ** 2 - 4 * q[:, 0] * n[:, 0]  # Delta_S x^2 on the unit sphere

        def error(v):
            return 100 * np.abs(v - exact).max() / np.abs(exact).max()

        for kernel in ("chord", "intrinsic"):
            op = s.MatrixFreeSurfaceOperator(surfels, mu, kernel=kernel)
            half = s.MatrixFreeSurfaceOperator(surfels, mu, kernel=kernel, t=op.t / 2)
            full_g, half_g = op.matvec(g)[:, 0], half.matvec(g)[:, 0]
            print("| %g | %s | %.2f%% | %.2f%% | %.2f%% |" % (h, kernel, error(full_g), error(half_g), error(2 * half_g - full_g)), flush=True)


if __name__ == "__main__":
    main()
