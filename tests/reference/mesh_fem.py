"""The pipeline digilap's users run today, as a reference: marching cubes, a linear FEM, shift-invert.

This is what LaPy / BrainPrint / ShapeDNA do with a voxel structure (issues 22, 23): a
triangle mesh from scikit-image's marching cubes at level 0.5, optionally smoothed by Taubin's
filter (lambda = 0.5, mu = -0.53, uniform weights), the linear (P1) finite element stiffness
(cotangent weights) and consistent mass matrices, and the smallest eigenpairs of K x = lambda M x
by SciPy's ``eigsh`` in shift-invert mode (sigma = -0.01, SuperLU). It is written here, in the
tests and the benchmarks, never a dependency of the library.

Written from the textbook formulas (Pinkall-Polthier cotangents; Reuter et al., "Laplace-
Beltrami spectra as Shape-DNA", 2006; Taubin 1995), not from LaPy's source.

Arrays follow digilap.surface's convention: ``mask[i, j, k]`` is voxel (i, j, k), whose centre
is at h * (i, j, k); the mesh vertices are in the same coordinates.
"""
import numpy as np
import scipy.sparse
import scipy.sparse.linalg

TAUBIN_LAMBDA, TAUBIN_MU = 0.5, -0.53


def marching_cubes(mask, h=1.0, level=0.5):
    """(vertices, faces) of the level set of the 0/1 mask; one voxel of zero padding closes it."""
    from skimage.measure import marching_cubes as skimage_marching_cubes  # tests only

    padded = np.pad(np.asarray(mask, dtype=np.float32), 1)
    verts, faces, _, _ = skimage_marching_cubes(padded, level=level, spacing=(h, h, h), allow_degenerate=False)
    return verts - h, faces.astype(np.int64)  # undo the padding: voxel (i, j, k) at h (i, j, k)


def _umbrella(vertices, faces):
    """The uniform-weight averaging operator: row i averages the mesh neighbours of vertex i."""
    n = len(vertices)
    i = np.concatenate([faces[:, 0], faces[:, 1], faces[:, 2], faces[:, 1], faces[:, 2], faces[:, 0]])
    j = np.concatenate([faces[:, 1], faces[:, 2], faces[:, 0], faces[:, 0], faces[:, 1], faces[:, 2]])
    adjacency = scipy.sparse.csr_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    adjacency.data[:] = 1.0  # an edge shared by two triangles counts once
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return scipy.sparse.diags(1.0 / np.maximum(degree, 1)) @ adjacency


def taubin(vertices, faces, iterations, lam=TAUBIN_LAMBDA, mu=TAUBIN_MU):
    """Taubin's lambda|mu smoothing: each iteration one shrinking and one inflating umbrella step."""
    average = _umbrella(vertices, faces)
    v = np.array(vertices, dtype=float)
    for _ in range(iterations):
        v += lam * (average @ v - v)
        v += mu * (average @ v - v)
    return v


def fem_matrices(vertices, faces):
    """(K, M): P1 stiffness (cotangent weights, K = sum over triangles of cot/2) and consistent mass."""
    n = len(vertices)
    p = [vertices[faces[:, c]] for c in range(3)]
    doubled_area = np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0]), axis=1)
    doubled_area = np.maximum(doubled_area, 1e-300)  # a degenerate triangle adds nothing below
    rows, cols, stiffness = [], [], []
    for c in range(3):  # the angle at corner c faces the edge (a, b)
        a, b = (c + 1) % 3, (c + 2) % 3
        u, w = p[a] - p[c], p[b] - p[c]
        cot = np.einsum("ij,ij->i", u, w) / doubled_area
        rows += [faces[:, a], faces[:, b]]
        cols += [faces[:, b], faces[:, a]]
        stiffness += [-0.5 * cot, -0.5 * cot]
    rows, cols, stiffness = np.concatenate(rows), np.concatenate(cols), np.concatenate(stiffness)
    off = scipy.sparse.csr_matrix((stiffness, (rows, cols)), shape=(n, n))
    K = off - scipy.sparse.diags(np.asarray(off.sum(axis=1)).ravel())
    area = doubled_area / 2
    mass_rows = np.concatenate([faces[:, a] for a in range(3) for _ in range(3)])
    mass_cols = np.concatenate([faces[:, b] for _ in range(3) for b in range(3)])
    mass_vals = np.concatenate([area * (2.0 if a == b else 1.0) / 12.0 for a in range(3) for b in range(3)])
    M = scipy.sparse.csr_matrix((mass_vals, (mass_rows, mass_cols)), shape=(n, n))
    return K.tocsc(), M.tocsc()


def area_and_volume(vertices, faces):
    """The mesh's area and the volume it encloses (divergence theorem, absolute value)."""
    p = [vertices[faces[:, c]] for c in range(3)]
    area = 0.5 * np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0]), axis=1).sum()
    volume = abs(np.einsum("ij,ij->i", p[0], np.cross(p[1], p[2])).sum()) / 6.0
    return area, volume


def smallest_eigenvalues(K, M, count, sigma=-0.01):
    """The ``count`` smallest eigenvalues of K x = lambda M x (the first is 0 per closed component)."""
    values = scipy.sparse.linalg.eigsh(K, k=count, M=M, sigma=sigma, which="LM", return_eigenvectors=False)
    return np.sort(values)


def shape_dna(mask, h=1.0, count=20, smoothing=10):
    """The peer pipeline in one call: dict with ``eigenvalues`` (count), ``area``, ``volume``, ``vertices``."""
    vertices, faces = marching_cubes(mask, h)
    if smoothing:
        vertices = taubin(vertices, faces, smoothing)
    K, M = fem_matrices(vertices, faces)
    area, volume = area_and_volume(vertices, faces)
    count = min(count, len(vertices) - 1)
    return {"eigenvalues": smallest_eigenvalues(K, M, count), "area": area, "volume": volume,
            "vertices": len(vertices)}


def gauss_digitization(inside, h, box):
    """The Gauss digitization of {inside(x, y, z)} at step h over box = (lo, hi): mask[i, j, k] with
    voxel (i, j, k) centred at h (i, j, k) (SPEC §7's convention), cropped to [lo, hi]^3."""
    lo, hi = int(np.floor(box[0] / h)) - 1, int(np.ceil(box[1] / h)) + 1
    axis = h * np.arange(lo, hi + 1)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return inside(x, y, z)


def sphere_spectrum(count, radius=1.0):
    """The exact spectrum of the sphere: l (l + 1) / r^2 with multiplicity 2 l + 1."""
    values = [l * (l + 1.0) / radius**2 for l in range(int(np.sqrt(count)) + 2) for _ in range(2 * l + 1)]
    return np.array(values[:count])


def torus_spectrum(count, R=1.0, r=0.4, points=4096):
    """The spectrum of the torus (R, r) by separation of variables: with w = R + r cos(phi) and
    f = e^(i n theta) u(phi), -(w u')' + r^2 n^2 u / w = lambda r^2 w u over periodic u
    (multiplicity 2 for n > 0). The periodic problem in phi is solved by second-order finite
    differences on `points` nodes (relative error ~ (2 pi / points)^2, 2e-6 by default)."""
    import scipy.sparse.linalg as sla

    d = 2 * np.pi / points
    phi = d * np.arange(points)
    w = R + r * np.cos(phi)
    w_half = R + r * np.cos(phi + d / 2)  # the flux between node j and j + 1
    j = np.arange(points)
    nxt = (j + 1) % points
    stiffness = scipy.sparse.csr_matrix(
        (np.concatenate([w_half + np.roll(w_half, 1), -w_half, -w_half]) / d,
         (np.concatenate([j, j, nxt]), np.concatenate([j, nxt, j]))), shape=(points, points))
    mass = scipy.sparse.diags(r * r * w * d)
    values = []
    for n in range(0, count + 1):
        K = stiffness + scipy.sparse.diags(r * r * n * n * d / w)
        k = min(count, points - 2)
        lam = np.sort(sla.eigsh(K.tocsc(), k=k, M=mass.tocsc(), sigma=-0.01, which="LM", return_eigenvectors=False))
        values += list(lam) * (1 if n == 0 else 2)
        if n > 0 and lam[0] > sorted(values)[count - 1]:
            break  # every further n starts above the count-th value
    return np.sort(np.array(values))[:count]
