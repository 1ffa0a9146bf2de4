#!/usr/bin/env python3
"""digilap beside the mesh pipeline (marching cubes + linear FEM + shift-invert eigsh, the way
LaPy / BrainPrint compute ShapeDNA) on every label of a real segmentation (issue 22).

Both methods get the same voxels: the largest 6-connected component of each label, and of its
boundary the largest closed surface (digilap: ``largest=True``; the mesh: its largest connected
component), so that each spectrum has exactly one zero eigenvalue. Writes a CSV with both
methods' first eigenvalues, areas and volumes per label, and prints a Markdown summary.

  PYTHONPATH=build/python /usr/bin/python3 bench/atlas_vs_fem.py \\
      ../shared/data/JHU-WhiteMatter-labels-1mm.nii.gz --names ../shared/data/JHU-WhiteMatter-labels-1mm.nii.txt \\
      --csv docs/atlas_vs_fem.csv
"""
import argparse
import os
import pathlib
import sys
import time

import numpy as np
import scipy.ndimage
import scipy.sparse
import scipy.sparse.csgraph

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests" / "reference"))
import mesh_fem  # noqa: E402  (the reference pipeline, shared with the tests)

import digilap.surface  # noqa: E402


def largest_component(mask):
    labelled, count = scipy.ndimage.label(mask)  # 6-connectivity, as digilap's objects
    if count <= 1:
        return mask, count
    sizes = np.bincount(labelled.ravel())[1:]
    return labelled == 1 + int(np.argmax(sizes)), count


def largest_mesh_component(vertices, faces):
    n = len(vertices)
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]]])
    graph = scipy.sparse.csr_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    count, which = scipy.sparse.csgraph.connected_components(graph, directed=False)
    keep = np.bincount(which).argmax()
    kept = which == keep
    renumber = np.cumsum(kept) - 1
    faces = faces[kept[faces[:, 0]]]
    return vertices[kept], renumber[faces]


def fem_spectrum(mask, h, count, smoothing):
    vertices, faces = mesh_fem.marching_cubes(mask, h)
    vertices, faces = largest_mesh_component(vertices, faces)
    if smoothing:
        vertices = mesh_fem.taubin(vertices, faces, smoothing)
    K, M = mesh_fem.fem_matrices(vertices, faces)
    area, volume = mesh_fem.area_and_volume(vertices, faces)
    return mesh_fem.smallest_eigenvalues(K, M, min(count, len(vertices) - 2)), area, volume, len(vertices)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("volume")
    parser.add_argument("--names", default="")
    parser.add_argument("--count", type=int, default=20)
    parser.add_argument("--smoothing", type=int, default=10, help="Taubin iterations of the mesh (BrainPrint: none)")
    parser.add_argument("--csv", default="atlas_vs_fem.csv")
    parser.add_argument("--quiet", action="store_true")
    parser.add_argument("--kernel", default=None, help="digilap's surface kernel: chord or intrinsic (default: the library's)")
    args = parser.parse_args()

    import nibabel

    image = nibabel.load(args.volume)
    zooms = image.header.get_zooms()[:3]
    if max(zooms) - min(zooms) > 1e-6 * max(zooms):
        sys.exit("atlas_vs_fem: the voxels are not cubes (%s)" % (zooms,))
    h = float(zooms[0])
    seg = np.asarray(image.dataobj).astype(np.int64)
    labels = [int(v) for v in np.unique(seg) if v != 0]
    names = digilap.surface.read_label_names(args.names) if args.names else {}
    rows, summary = [], []
    totals = {"digilap": 0.0, "fem": 0.0}
    for n, label in enumerate(labels):
        if not args.quiet:
            print("\ratlas_vs_fem: label %d (%d/%d)" % (label, n + 1, len(labels)), end="", file=sys.stderr, flush=True)
        mask, components = largest_component(seg == label)
        start = time.perf_counter()
        table = digilap.surface.shape_dna(mask.astype(np.uint8), labels=[1], count=args.count, h=h, largest=True,
                                          **({"kernel": args.kernel} if args.kernel else {}))
        totals["digilap"] += time.perf_counter() - start
        start = time.perf_counter()
        fem, fem_area, fem_volume, vertices = fem_spectrum(mask, h, args.count, args.smoothing)
        totals["fem"] += time.perf_counter() - start
        ours = table["eigenvalues"][0]
        name = names.get(label, str(label))
        rows.append([label, name, "digilap", table["area"][0], table["volume"][0]] + list(ours))
        rows.append([label, name, "fem_taubin%d" % args.smoothing, fem_area, fem_volume]
                    + list(fem) + [np.nan] * (args.count - len(fem)))
        k = min(len(fem), args.count)
        rel = ours[1:k] / fem[1:k] - 1
        summary.append((label, name, int(mask.sum()), components, vertices, table["area"][0], fem_area,
                        table["volume"][0], fem_volume, ours[1], fem[1], np.nanmedian(rel), rel[np.nanargmax(np.abs(rel))]))
    if not args.quiet:
        print(file=sys.stderr)
    with open(args.csv, "w") as out:
        out.write("label,name,method,area,volume," + ",".join("ev%d" % i for i in range(args.count)) + "\n")
        for r in rows:
            out.write(",".join([str(r[0]), r[1], r[2]] + ["%.10g" % v for v in r[3:]]) + "\n")
    print("| label | name | voxels | comp. | mesh vertices | area digilap / mesh | volume digilap / mesh "
          "| λ1 digilap / mesh | median λ/λ_mesh − 1 (ev1–ev%d) | largest |" % (args.count - 1))
    print("|---|---|---|---|---|---|---|---|---|---|")
    for s in summary:
        print("| %d | %s | %d | %d | %d | %.0f / %.0f | %.0f / %.0f | %.4g / %.4g | %+.2f%% | %+.2f%% |"
              % (s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], s[8], s[9], s[10], 100 * s[11], 100 * s[12]))
    med = np.array([s[11] for s in summary])
    area = np.array([s[5] / s[6] - 1 for s in summary])
    print("\n%d labels, h = %g mm, %d eigenvalues; mesh: Taubin %d. median over labels of the median "
          "λ/λ_mesh − 1: %+.2f%% (range %+.2f%% … %+.2f%%); area digilap/mesh − 1: median %+.2f%%. "
          "Time in this process: digilap %.1f s, mesh pipeline %.1f s."
          % (len(summary), h, args.count, args.smoothing, 100 * np.median(med), 100 * med.min(), 100 * med.max(),
             100 * np.median(area), totals["digilap"], totals["fem"]))
    print("wrote %s" % os.path.abspath(args.csv))


if __name__ == "__main__":
    main()
