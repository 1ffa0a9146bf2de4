#!/usr/bin/env python3
"""The II normals' area against the ball radius, with and without the digital ball's anisotropy
(issue 23): a reference surface digitized at h (centre off the lattice, as the tests pose it), the
area sum(mu) = h^2 sum |n . e| from the II normals with R = rho h for rho = 3 ... 8 voxels, against
the exact area, for the default estimator and the plain one of SPEC §7
(remove_ball_anisotropy=False), and the exact normals' area at the same h for scale. Prints a
Markdown table (docs/accuracy.md, "The digital ball's anisotropy").

  PYTHONPATH=build/python /usr/bin/python3 bench/ii_ball_anisotropy.py --shape sphere --h 0.03 0.015

A curve (--shape circle, flower, ...) measures the same for the 2D II normals (disks around the
linels' centres; its length instead of the area, the plain estimator only: the 2D library has no
correction yet).
"""
import argparse

import numpy as np

import digilap
from digilap import surface

CENTRE = np.array([0.0123, -0.0371, 0.0217])  # tests/surface/support.hpp's kCentre


def rotation():
    """The tests' pose: 0.3 rad about (1, 2, 3)."""
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(0.3) * k + (1 - np.cos(0.3)) * k @ k


def curve_table(name, steps, radii):
    """The 2D sibling: the length sum(mu) from the plain II normals against rho (pixels)."""
    shape = digilap.make_shape(name)
    shape.set_pose(CENTRE[:2], 0.3)
    print("| h | linels | exact normals | estimator | length error at rho = " + " / ".join("%g" % r for r in radii)
          + " | largest |error| |")
    print("|---|---|---|---|---|---|")
    for h in steps:
        pixels = digilap.digitize(shape, h)
        contours = digilap.track_contours(pixels)
        length = shape.length()
        exact = digilap.measures(contours, digilap.exact_normals(shape, contours, 1.0)).total_length() / length - 1
        errors = 100 * np.array([digilap.measures(contours, digilap.ii_normals(pixels, contours, k_R=rho * h / np.cbrt(h),
                                                                               length_scale=1.0)).total_length() / length - 1
                                 for rho in radii])
        print("| %g | %d | %+.3f%% | plain (SPEC §2) | %s | %.2f%% |" % (
            h, contours.linel_count(), 100 * exact, " / ".join("%+.2f" % e for e in errors), np.abs(errors).max()),
            flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shape", default="sphere", help="a surface (sphere, ellipsoid, torus) or a curve (circle, ...)")
    parser.add_argument("--h", type=float, nargs="+", default=[0.03])
    parser.add_argument("--rho", type=float, nargs=3, default=[3.0, 8.0, 0.25], metavar=("FIRST", "LAST", "STEP"))
    args = parser.parse_args()
    radii = np.arange(args.rho[0], args.rho[1] + 1e-9, args.rho[2])
    if args.shape not in surface.surface_names():
        curve_table(args.shape, args.h, radii)
        return
    shape = surface.make_surface(args.shape)
    shape.set_pose(CENTRE, rotation())
    print("| h | N | exact normals | estimator | area error at rho = " + " / ".join("%g" % r for r in radii)
          + " | largest |error| |")
    print("|---|---|---|---|---|---|")
    for h in args.h:
        voxels = surface.digitize(shape, h)
        surfels = surface.extract_surfels(voxels)
        area = shape.area()
        exact = surface.measures(surfels, surface.exact_normals(shape, surfels, 1.0)).total_area() / area - 1
        for plain in (True, False):
            errors = []
            for rho in radii:
                normals = surface.ii_normals(voxels, surfels, k_R=rho * h / np.cbrt(h), length_scale=1.0,
                                             remove_ball_anisotropy=not plain)
                errors.append(surface.measures(surfels, normals).total_area() / area - 1)
            errors = 100 * np.array(errors)
            print("| %g | %d | %+.2f%% | %s | %s | %.2f%% |" % (
                h, len(surfels), 100 * exact, "plain (SPEC §7)" if plain else "default",
                " / ".join("%+.2f" % e for e in errors), np.abs(errors).max()), flush=True)


if __name__ == "__main__":
    main()
