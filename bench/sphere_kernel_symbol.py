#!/usr/bin/env python3
"""The geodesic heat-kernel operator's symbol on the exact unit sphere, and the bias of its
Laplace-Beltrami estimates (docs/accuracy.md, "Why the torus stalled").

On the unit sphere the operator (1/t) sum_j w(d_ij) c_i c_j (f_j - f_i) mu_j, in the continuum
limit, has the spherical harmonics of degree l as eigenfunctions; its eigenvalue is the
quadrature of the Gaussian of the geodesic distance theta against 1 - P_l(cos theta) over the
cap theta < k sqrt(t), times the curvature factors (1 + g)^2, g = coefficient * t * K (K = 1).
The estimate then inverts a symbol: the whole Gaussian's (-ln(1 - lambda t)/t) or the cut
kernel's (what laplace_beltrami_eigenvalues does with a KernelCut). Printed: the estimate's
relative error over t, for each l, which is the bias's first-order coefficient.

    /usr/bin/python3 bench/sphere_kernel_symbol.py --factor 0 --inversion cut      # the Gaussian's own bias: about -1
    /usr/bin/python3 bench/sphere_kernel_symbol.py --factor 0.6667 --inversion whole  # before issue 23's fix
    /usr/bin/python3 bench/sphere_kernel_symbol.py --factor 0.5 --inversion cut     # now: about 0
"""
import argparse

import numpy as np
from scipy import optimize, special

NODES, WEIGHTS = np.polynomial.legendre.leggauss(400)


def on_interval(lo, hi):
    return 0.5 * (hi - lo) * (NODES + 1) + lo, 0.5 * (hi - lo) * WEIGHTS


def sphere_eigenvalue(l, t, k, factor):
    """(1/t) times the cap's integral of G(theta) (1 - P_l(cos theta)) dA, times (1 + factor t)^2."""
    theta, w = on_interval(0.0, k * np.sqrt(t))
    gaussian = np.exp(-theta**2 / (4 * t)) / (4 * np.pi * t)
    integral = np.sum(w * gaussian * (1 - special.eval_legendre(l, np.cos(theta))) * 2 * np.pi * np.sin(theta))
    return integral / t * (1 + factor * t) ** 2


def flat_cut_symbol(mu, t, k):
    """F(mu t) / t of the flat kernel cut at k sqrt(t) (r = |y| / 2 sqrt(t) in [0, k/2])."""
    r, w = on_interval(0.0, k / 2)
    return np.sum(w * 2 * r * np.exp(-r * r) * (1 - special.j0(2 * np.sqrt(mu * t) * r))) / t


def estimate(lam, t, k, inversion):
    whole = -np.log1p(-lam * t) / t
    if inversion == "whole":
        return whole
    return optimize.brentq(lambda mu: flat_cut_symbol(mu, t, k) - lam, 0.5 * whole, 2 * whole + 1)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--factor", type=float, default=0.5, help="g / (t K): 0.5 now, 2/3 before, 0 for none")
    parser.add_argument("--inversion", choices=["cut", "whole"], default="cut")
    parser.add_argument("--k", type=float, default=6.0)
    parser.add_argument("--t", type=float, nargs="+", default=[5e-4, 1e-3, 2e-3, 4e-3, 8e-3])
    parser.add_argument("--l", type=int, nargs="+", default=[1, 2, 3, 4])
    args = parser.parse_args()
    print("| t | " + " | ".join("l = %d: rel. error / t" % l for l in args.l) + " |")
    print("|---|" + "---|" * len(args.l))
    for t in args.t:
        cells = []
        for l in args.l:
            exact = l * (l + 1.0)
            mu = estimate(sphere_eigenvalue(l, t, args.k, args.factor), t, args.k, args.inversion)
            cells.append("%+.4f" % ((mu / exact - 1) / t))
        print("| %g | %s |" % (t, " | ".join(cells)))


if __name__ == "__main__":
    main()
