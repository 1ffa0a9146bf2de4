"""The spectra of every structure of a label volume (ShapeDNA, as BrainPrint users know it), and
a picture: the eigenvalue curves of all structures and one structure's first eigenvectors.

    PYTHONPATH=build/python python3 examples/python/atlas_spectra.py [atlas.nii.gz] [names.txt] [out.png]

Without arguments: the 2 mm white-matter atlas committed in tests/data (48 tracts).
"""
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import nibabel  # noqa: E402
import numpy as np  # noqa: E402

import digilap  # noqa: E402
import digilap.surface  # noqa: E402

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data"


def main():
    atlas = sys.argv[1] if len(sys.argv) > 1 and sys.argv[1] else str(DATA / "JHU-WhiteMatter-labels-2mm.nii.gz")
    table = sys.argv[2] if len(sys.argv) > 2 and sys.argv[2] else str(DATA / "JHU-WhiteMatter-labels-2mm.nii.txt")
    names = digilap.surface.read_label_names(table)
    out = sys.argv[3] if len(sys.argv) > 3 else "atlas_spectra.png"

    image = nibabel.load(atlas)
    seg = np.asarray(image.dataobj)  # seg[i, j, k]: the convention of digilap.surface.from_mask
    h = float(image.header.get_zooms()[0])
    table = digilap.surface.shape_dna(seg, count=20, h=h, largest=True)
    ok = [r for r, status in enumerate(table["status"]) if status == "ok"]
    print("%d structures, %d with a spectrum (h = %g mm)" % (len(table["labels"]), len(ok), h))
    for r, status in enumerate(table["status"]):
        if status != "ok":
            print("  label %d: %s" % (table["labels"][r], status))

    fig = plt.figure(figsize=(13, 5))
    curves = fig.add_subplot(1, 3, 1)
    for r in ok:  # lambda_i * area: the scale-free curves (Weyl: ~ 4 pi i)
        curves.plot(np.arange(20), table["eigenvalues"][r] * table["area"][r], lw=0.8, alpha=0.7)
    curves.plot(np.arange(20), 4 * np.pi * np.arange(20), "k--", lw=1.2, label="Weyl: 4π i")
    curves.set_xlabel("i")
    curves.set_ylabel("λ_i · area")
    curves.set_title("ShapeDNA of %d structures" % len(ok))
    curves.legend()

    # One structure, its surface and first two non-constant eigenvectors.
    big = max(ok, key=lambda r: table["area"][r])
    label = int(table["labels"][big])
    voxels = digilap.surface.from_mask(seg, h=h, label=label)
    surfels = digilap.surface.filter_surfels(voxels, digilap.surface.extract_surfels(voxels), largest_only=True)
    op = digilap.surface.heat_laplacian(surfels, digilap.surface.measures(surfels, digilap.surface.ii_normals(voxels, surfels)))
    spectrum = digilap.smallest_eigenpairs(op, 3)
    centres = np.asarray(surfels.centres)
    for panel, k in enumerate((1, 2)):
        ax = fig.add_subplot(1, 3, 2 + panel, projection="3d")
        phi = spectrum.eigenvectors[:, k]
        limit = np.abs(phi).max()
        ax.scatter(centres[:, 0], centres[:, 1], centres[:, 2], c=phi, cmap="RdBu_r", vmin=-limit, vmax=limit, s=2)
        ax.set_title("%s: φ_%d, λ = %.4g mm⁻²" % (names.get(label, str(label)), k, spectrum.laplace_beltrami[k]))
        ax.set_axis_off()
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote %s" % out)


if __name__ == "__main__":
    main()
