#!/usr/bin/env python3
"""Removing the heat kernel's O(t) bias from pointwise estimates (issue 23): the max error of x^2
on the unit sphere (SPEC §7, closest-point sampling, centre off the lattice, defaults: intrinsic
kernel, l measured), matrix-free, for

  L g                              the operator
  L g - (t/2) L L g                the log series ln(I + tL)/t = L - (t/2) L^2 + ..., first term
  L g - (t/2) L_4t L g             the second product with a wider kernel (4t: less noise, 4x the cost)
  L g - (t/2) L (I + t L) L g      one heat step before the second product (digilap.bias_corrected_laplacian)

and, for L g, where the worst surfel is and what is left there once the predicted bias
(t/2) Delta^2 x^2 = 18 t (x^2 - 1/3) is taken off.

  PYTHONPATH=build/python /usr/bin/python3 bench/pointwise_bias_correction.py 0.1 0.05 0.025
"""
import sys

import numpy as np

import digilap.surface as s

CENTRE = np.array([0.0123, -0.0371, 0.0217])


def main():
    sphere = s.make_surface("sphere")
    sphere.set_pose(CENTRE, np.eye(3))
    print("| h | N | L g | L − (t/2) L² | L − (t/2) L_4t L | L − (t/2) L (I + tL) L | L g at the worst surfel: error, predicted bias, normal |")
    print("|---|---|---|---|---|---|---|")
    for h in map(float, sys.argv[1:] or ["0.1", "0.05"]):
        voxels = s.digitize(sphere, h)
        surfels = s.extract_surfels(voxels)
        mu = s.measures(surfels, s.ii_normals(voxels, surfels))
        q = np.array([sphere.closest_point(x) for x in np.asarray(surfels.centres)]) - CENTRE  # = the normal
        g = (q[:, 0] ** 2).reshape(-1, 1)
        exact = 2 - 6 * q[:, 0] ** 2  # Delta_S x^2 on the unit sphere
        scale = np.abs(exact).max()

        def error(v):
            return 100 * np.abs(v - exact).max() / scale

        op = s.MatrixFreeSurfaceOperator(surfels, mu)
        t = op.t
        lg = op.matvec(g)[:, 0]
        squared = lg - t / 2 * op.matvec(lg)[:, 0]
        wide = lg - t / 2 * s.MatrixFreeSurfaceOperator(surfels, mu, t=4 * t).matvec(lg)[:, 0]
        corrected = op.bias_corrected_matvec(g)[:, 0]
        worst = np.argmax(np.abs(lg - exact))
        bias = t / 2 * 36 * (q[worst, 0] ** 2 - 1 / 3)
        print("| %g | %d | %.2f%% | %.2f%% | %.2f%% | **%.2f%%** | %+.2f%%, %+.2f%%, (%.2f, %.2f, %.2f) |" % (
            h, len(g), error(lg), error(squared), error(wide), error(corrected), 100 * (lg - exact)[worst] / scale,
            100 * bias / scale, *q[worst]), flush=True)


if __name__ == "__main__":
    main()
