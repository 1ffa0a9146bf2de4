"""From a mask to a picture of the first eigenvectors of the Laplace-Beltrami operator on its
contour: colour = value of the eigenvector at each boundary element.

    PYTHONPATH=build/python python3 examples/python/eigenvectors.py [mask.png] [out.png]

Without a file the mask is a drawn shape (a disc with two bumps and a notch).
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import digilap  # noqa: E402


def drawn_mask(size=240):
    yy, xx = np.mgrid[0:size, 0:size] / size
    disc = (xx - 0.5) ** 2 + (yy - 0.55) ** 2 < 0.3**2
    bumps = ((xx - 0.28) ** 2 + (yy - 0.25) ** 2 < 0.12**2) | ((xx - 0.75) ** 2 + (yy - 0.3) ** 2 < 0.09**2)
    notch = (np.abs(xx - 0.5) < 0.04) & (yy > 0.7)
    return (disc | bumps) & ~notch


def main():
    out = sys.argv[2] if len(sys.argv) > 2 else "eigenvectors.png"
    if len(sys.argv) > 1 and sys.argv[1]:
        digital = digilap.read_image(sys.argv[1])
    else:
        digital = digilap.from_mask(drawn_mask())
    contours = digilap.filter_contours(digilap.track_contours(digital), largest_only=True)
    op = digilap.heat_laplacian(contours, digilap.measures(contours, digilap.ii_normals(digital, contours)))
    spectrum = digilap.smallest_eigenpairs(op, 7)
    xy = op.positions
    fig, axes = plt.subplots(2, 3, figsize=(10, 6.6))
    for k, ax in zip(range(1, 7), axes.flat):
        phi = spectrum.eigenvectors[:, k]
        limit = np.abs(phi).max()
        ax.scatter(xy[:, 0], xy[:, 1], c=phi, cmap="coolwarm", vmin=-limit, vmax=limit, s=4)
        ax.set_title(f"phi_{k}, Laplace-Beltrami lambda = {spectrum.laplace_beltrami[k]:.4g}", fontsize=9)
        ax.set_aspect("equal")
        ax.axis("off")
    fig.suptitle(f"Eigenvectors on the contour (N = {op.rows()}, t = {op.t:.3g})")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
