#!/usr/bin/env python3
"""Why the torus spectrum stalls near 2.6% (issue 23): the kernel's distance, measured.

The heat-kernel operator uses the chord |x_i - x_j|. Along a normal section of curvature k the
chord is shorter than the geodesic distance rho: |x_i - x_j|^2 = rho^2 - k^2 rho^4 / 12 + O(rho^6),
so exp(-|x_i - x_j|^2 / 4t) over-weights far neighbours by exp(k^2 rho^4 / 48t). Integrated against
the Gaussian's moments (E[rho^2k] = k! (4t)^k in two dimensions) that scales the second-order term
by 1 + 2 t <k_n^2>, with <.> the kernel-weighted normal curvature in the direction the function
varies: on the unit sphere +2t in all directions, on the torus's tube (k = 1/r = 2.5) about
(5/4) t / r^2 for the modes that vary around it: 3% at t = 0.004 (h = 0.025). The geodesic
Gaussian has its own bias, -(4/3) K t (K Gaussian curvature), which on the sphere offsets most
of the chord's +2t and is why the sphere is at 0.3%.

This script rebuilds the operator from digilap's surfels, measures and normals with SciPy and
swaps the distance:
  chord      |x_i - x_j|^2 (digilap's operator; checked against it, 1e-12)
  geodesic   |x_i - x_j|^2 + <x_j - x_i, n_j - n_i>^2 / 12, the second-order geodesic distance
             from the normals (<x_j - x_i, n_j - n_i> = k_n rho^2 + O(rho^3) in any direction)
  tangent    |x_i - x_j|^2 - <x_j - x_i, m>^2, m = (n_i + n_j) / |n_i + n_j|: the chord in the mean
             tangent plane, without the staircase's jitter of the surfel centres along the normal
             (+-h/2, which lengthens every chord by about h^2/6 and biases the weights by ~h^2/24t)
  tangent-geodesic  the tangent chord plus the geodesic term
  tangent-geodesic+K  the same, each weight times 1 + (2/3) t (K_i + K_j) with the exact Gaussian
             curvature K (reference shapes only): the geodesic Gaussian's own bias, -(4/3) K t, out
  tangent-geodesic+Kest  the same with K estimated from the positions and normals alone
and prints the worst relative error of the first 19 nonzero eigenvalues (after -ln(1 - lt)/t)
against the exact spectrum (torus by separation of variables, sphere l(l+1)), for II and exact
normals, at the default t and at t scaled by --t-scales.

  PYTHONPATH=build/python /usr/bin/python3 bench/torus_study.py --shape torus --h 0.05 0.035
"""
import argparse
import pathlib
import sys

import numpy as np
import scipy.sparse
import scipy.sparse.linalg
from scipy.spatial import cKDTree

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests" / "reference"))
import mesh_fem  # noqa: E402
import digilap.surface as s  # noqa: E402

CENTRE = [0.0123, -0.0371, 0.0217]


def pipeline(shape, h, normals_kind):
    surface = s.make_surface(shape)
    surface.set_pose(CENTRE, np.eye(3))
    voxels = s.digitize(surface, h)
    surfels = s.extract_surfels(voxels)
    ii = s.ii_normals(voxels, surfels)
    normals = ii if normals_kind == "ii" else s.exact_normals(surface, surfels)
    mu = s.measures(surfels, normals)
    return surfels, mu, np.asarray(normals.normals)


def gaussian_curvature(shape, x):
    """The exact Gaussian curvature at the points' closest points (sphere r = 1, torus R = 1, r = 0.4)."""
    c = x - np.array(CENTRE)
    if shape == "sphere":
        return np.ones(len(x))
    rho = np.hypot(c[:, 0], c[:, 1])
    cos_phi = (rho - 1.0) / np.hypot(rho - 1.0, c[:, 2])
    return cos_phi / (0.4 * (1.0 + 0.4 * cos_phi))


def neighbour_pairs(x, n, t, k):
    """The pairs i < j within the cut k sqrt(t), their chords x_j - x_i, the squared chords, and the
    squared heights <x_j - x_i, m>^2 along the mean normal m = (n_i + n_j) / |n_i + n_j|."""
    pairs = cKDTree(x).query_pairs(k * np.sqrt(t), output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    dx = x[j] - x[i]
    mean_n = n[i] + n[j]
    height2 = np.einsum("ij,ij->i", dx, mean_n) ** 2 / np.einsum("ij,ij->i", mean_n, mean_n)
    return i, j, dx, np.einsum("ij,ij->i", dx, dx), height2


def estimated_gaussian_curvature(x, n, mu, t, k):
    """K per surfel from the kernel-weighted pair moments of positions and normals alone (no exact
    geometry): with rho^2 the tangent chord, <dx, dn> / rho^2 averages the normal curvature over
    directions, H, and |dn|^2 / rho^2 averages |S e|^2, (k1^2 + k2^2) / 2; K = k1 k2 = 2 H^2 -
    (k1^2 + k2^2) / 2. Both are ratios of sums weighted by w rho^2, so that the normals' noise,
    whose |dn|^2 does not shrink with rho, is not divided by small rho^2."""
    i, j, dx, chord2, height2 = neighbour_pairs(x, n, t, k)
    rho2 = chord2 - height2
    dn = n[j] - n[i]
    w = np.exp(-rho2 / (4 * t))
    sums = {}
    for name, value in (("weight", w * rho2), ("bend", w * np.einsum("ij,ij->i", dx, dn)), ("turn", w * np.einsum("ij,ij->i", dn, dn))):
        sums[name] = np.bincount(i, value * mu[j], len(x)) + np.bincount(j, value * mu[i], len(x))
    H = sums["bend"] / sums["weight"]
    return 2 * H * H - sums["turn"] / sums["weight"]


def stiffness(x, n, mu, t, k, distance, curvature=None):
    """K = -A (positive semidefinite): K_ij = -w_ij mu_i mu_j off the diagonal, rows summing to 0."""
    i, j, dx, d2, height2 = neighbour_pairs(x, n, t, k)
    if distance in ("tangent", "tangent-geodesic"):  # the normal component of the chord out: the staircase's jitter
        d2 = d2 - height2
    if distance in ("geodesic", "tangent-geodesic"):
        bend = np.einsum("ij,ij->i", dx, n[j] - n[i])
        d2 = d2 + bend * bend / 12
    if distance != "chord":
        keep = d2 <= k * k * t  # the cut on the corrected distance, as on the chord
        i, j, d2 = i[keep], j[keep], d2[keep]
    w = np.exp(-d2 / (4 * t)) / (4 * np.pi * t * t) * mu[i] * mu[j]
    if curvature is not None:  # the geodesic Gaussian's -(4/3) K t, taken out symmetrically
        w = w * (1 + (2.0 / 3.0) * t * (curvature[i] + curvature[j]))
    N = len(x)
    off = scipy.sparse.coo_matrix((np.concatenate([-w, -w]), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(N, N)).tocsr()
    return off - scipy.sparse.diags(np.asarray(off.sum(axis=1)).ravel())


def spectrum(K, mu, count):
    """Smallest eigenvalues of K x = l M x on the support of mu, by Lanczos on M^-1/2 K M^-1/2."""
    keep = mu > 0
    scale = 1 / np.sqrt(mu[keep])
    B = scipy.sparse.diags(scale) @ K[keep][:, keep] @ scipy.sparse.diags(scale)
    values = scipy.sparse.linalg.eigsh(B, k=count, which="SA", tol=1e-10, return_eigenvectors=False)
    return np.sort(values)


def worst(values, exact, t):
    corrected = -np.log1p(-values * t) / t
    return np.max(np.abs(corrected[1:] / exact[1:len(values)] - 1)), corrected


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shape", default="torus")
    parser.add_argument("--h", type=float, nargs="+", default=[0.05])
    parser.add_argument("--count", type=int, default=20)
    parser.add_argument("--k", type=float, default=6.0)
    parser.add_argument("--t-scales", type=float, nargs="+", default=[1.0])
    parser.add_argument("--normals", nargs="+", default=["ii", "exact"])
    parser.add_argument("--distances", nargs="+", default=["chord", "tangent-geodesic", "tangent-geodesic+K"])
    parser.add_argument("--modes", action="store_true", help="print every mode's error")
    parser.add_argument("--distance-normals", choices=["same", "exact"], default="same",
                        help="the normals of the distance: those of the measures, or the exact ones (to separate the two roles)")
    args = parser.parse_args()
    exact = mesh_fem.torus_spectrum(args.count) if args.shape.startswith("torus") else mesh_fem.sphere_spectrum(args.count)
    print("| surface | h | N | normals | t / t_default | t | distance | worst error (ev1-ev%d) |" % (args.count - 1))
    print("|---|---|---|---|---|---|---|---|")
    for h in args.h:
        for normals_kind in args.normals:
            surfels, mu, n = pipeline(args.shape, h, normals_kind)
            x = np.asarray(surfels.centres)
            m = np.asarray(mu.mu)
            op = s.heat_laplacian(surfels, mu)
            t0 = op.t
            if args.distance_normals == "exact":
                n = pipeline(args.shape, h, "exact")[2]
            for scale in args.t_scales:
                t = t0 * scale
                for distance in args.distances:
                    curvature = None
                    if distance.endswith("+K"):
                        curvature = gaussian_curvature(args.shape, x)
                    elif distance.endswith("+Kest"):
                        curvature = estimated_gaussian_curvature(x, n, m, t, args.k)
                        exact_K = gaussian_curvature(args.shape, x)
                        print("  K estimated: mean |K_est - K| = %.3f (K from %.2f to %.2f)"
                              % (np.mean(np.abs(curvature - exact_K)), exact_K.min(), exact_K.max()))
                    K = stiffness(x, n, m, t, args.k, distance.split("+")[0], curvature)
                    if distance == "chord" and scale == 1.0 and normals_kind == "ii":  # the rebuild is digilap's operator
                        A = op.A
                        gap = abs(K + A).max() / abs(A).max()
                        assert gap < 1e-12, gap
                    values = spectrum(K, m, args.count)
                    err, corrected = worst(values, exact, t)
                    print("| %s | %g | %d | %s | %g | %.5f | %s | %.2f%% |" % (args.shape, h, len(x), normals_kind, scale, t, distance,
                                                                             100 * err), flush=True)
                    if args.modes:
                        print("  modes: " + " ".join("%+.2f" % (100 * (c / e - 1)) for c, e in zip(corrected[1:], exact[1:])))


if __name__ == "__main__":
    main()
