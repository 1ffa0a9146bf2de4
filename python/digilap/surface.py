"""digilap.surface: the operator on the boundary of a voxel set (SPEC §7), the 3D half of digilap.

Volumes in (``read_volume``, ``read_labels``, ``from_mask`` on any 3-D NumPy array), surfels
grouped by connected surface, II normals, areas, the heat-kernel Laplacian (a
``digilap.HeatOperator`` of dimension 2: spectra, heat flow, smoothing and files are the same
functions as for contours), and the one-call entry points ``laplacian`` and ``shape_dna``.

Convention for arrays: ``volume[i, j, k]`` is voxel ``(i, j, k)``, as nibabel's
``get_fdata()`` gives it, so ``from_mask(nib.load(f).get_fdata(), label=3)`` is
``read_volume(f, label=3)``. (The ``.npy`` reader keeps NumPy's (plane, row, column) order,
``[k, j, i]``; the spectrum does not depend on the order of the axes.)
"""
import numpy as _np

from ._digilap import EIGENVALUES_ONLY_TOLERANCE as _EIGENVALUES_ONLY_TOLERANCE
from ._digilap import Error, smallest_eigenpairs as _smallest_eigenpairs
from ._digilap import surface as _cpp  # the C++ submodule (an attribute, not an importable module)

globals().update({_name: getattr(_cpp, _name) for _name in dir(_cpp) if not _name.startswith("_")})
enclosed_volume, extract_surfels, filter_surfels = _cpp.enclosed_volume, _cpp.extract_surfels, _cpp.filter_surfels
from_mask, heat_laplacian, ii_normals, measures, VoxelSet = (_cpp.from_mask, _cpp.heat_laplacian, _cpp.ii_normals,
                                                              _cpp.measures, _cpp.VoxelSet)

__all__ = [name for name in dir() if not name.startswith("_")] + ["laplacian", "shape_dna", "read_label_names"]


def _as_linear_operator(self):
    """L as a ``scipy.sparse.linalg.LinearOperator`` (matvec and matmat, for eigsh, cg,
    expm_multiply), computed on the fly: nothing of size N x neighbours is stored."""
    from scipy.sparse import linalg as _linalg

    n = self.rows()
    return _linalg.LinearOperator((n, n), matvec=lambda x: self.matvec(_np.asarray(x, float).reshape(n, -1))[:, 0],
                                  matmat=lambda x: self.matvec(_np.asarray(x, float)), dtype=_np.float64)


MatrixFreeSurfaceOperator.as_linear_operator = _as_linear_operator


def read_label_names(path):
    """``{index: name}`` from a label table: ``index name ...`` lines, as FSL's atlases ship them,
    or FreeSurfer's colour LUT (``index name R G B A``); '#' comments and other lines skipped."""
    names = {}
    with open(path) as table:
        for line in table:
            parts = line.split("#", 1)[0].split()
            if len(parts) >= 2 and parts[0].isdigit():
                names[int(parts[0])] = parts[1]
    return names


def _operator(volume_or_voxels, h, label, largest, min_surfels, k_R, options):
    if isinstance(volume_or_voxels, VoxelSet):
        voxels = volume_or_voxels
    else:
        voxels = from_mask(_np.asarray(volume_or_voxels), 1.0 if h is None else h, label)
    surfels = filter_surfels(voxels, extract_surfels(voxels), min_surfels, largest)
    normals = ii_normals(voxels, surfels) if k_R is None else ii_normals(voxels, surfels, k_R=k_R)
    mu = measures(surfels, normals)
    return surfels, mu, heat_laplacian(surfels, mu, **options)


def laplacian(volume_or_voxels, h=None, label=None, largest=False, min_surfels=8, k_R=None, **options):
    """``L, M = laplacian(volume, h=None, label=None, **options)``: the one-call operator of a volume.

    ``volume``: a 3-D NumPy array (bool or integer; a label map with ``label``) or a
    ``VoxelSet``; ``h``: the voxel size (default 1, voxel units). ``largest`` keeps the largest
    surface, ``min_surfels`` drops smaller ones; other keyword arguments go to
    ``heat_laplacian`` (``t``, ``c_t``, ``k``, ``couple_surfaces``, ...).

    Returns ``(L, M)`` as ``scipy.sparse.csr_matrix``, the convention of
    ``digilap.laplacian`` and robust_laplacian: ``L = -A`` symmetric positive semidefinite,
    ``M = diag(mu)`` (surfels of zero area have a zero row, column and mass: use
    ``digilap.smallest_eigenpairs(op)`` for spectra that handle them).
    """
    surfels, _, op = _operator(volume_or_voxels, h, label, largest, min_surfels, k_R, options)
    if len(surfels) == 0:
        raise Error("laplacian: no surface with at least %d surfels in the volume (is it empty?)" % min_surfels)
    return -op.A, op.M


def shape_dna(volume, labels=None, count=50, h=1.0, normalize="none", reweight=False, largest=False,
              tolerance=_EIGENVALUES_ONLY_TOLERANCE, **options):
    """The spectra of the structures of a label volume, as ShapeDNA and BrainPrint give them.

    ``labels``: the labels to take (default: every non-zero value of ``volume``).
    ``normalize``: ``'none'``, ``'surface'`` (lambda * area) or ``'volume'`` (lambda *
    volume^(2/3)); ``reweight``: lambda_i / i for i >= 1. Returns a dict of NumPy arrays:
    ``labels`` (n), ``area`` (n), ``volume`` (n), ``eigenvalues`` (n x count, the
    Laplace-Beltrami estimates; NaN past what a structure has, or for a structure that fails),
    ``raw`` (the operator's own eigenvalues, the same way) and ``status`` (``'ok'`` or the
    reason it failed). A failing structure never stops the others. ``tolerance``: the
    eigen-solver's (``smallest_eigenpairs``); the default, ``digilap.EIGENVALUES_ONLY_TOLERANCE``
    (1e-8), suits eigenvalues alone: they agree with those at 1e-10 within about 3e-11 relative.
    """
    if normalize not in ("none", "surface", "volume"):
        raise ValueError("normalize: expected 'none', 'surface' or 'volume', got %r" % (normalize,))
    volume = _np.asarray(volume)
    if labels is None:
        labels = [int(v) for v in _np.unique(volume) if v != 0]
    n = len(labels)
    out = {"labels": _np.asarray(labels), "area": _np.full(n, _np.nan), "volume": _np.full(n, _np.nan),
           "eigenvalues": _np.full((n, count), _np.nan), "raw": _np.full((n, count), _np.nan), "status": []}
    for row, label in enumerate(labels):
        try:
            if label == 0:
                raise ValueError("label 0 is the background")
            surfels, mu, op = _operator(volume, h, label, largest, 8, None, options)
            if len(surfels) == 0:
                raise ValueError("no surface with at least 8 surfels has the label %d" % label)
            support = op.rows() - len(op.massless_rows())
            spectrum = _smallest_eigenpairs(op, min(count, support - 1), tolerance=tolerance)
            k = len(spectrum.eigenvalues)
            out["area"][row], out["volume"][row] = mu.total_area(), enclosed_volume(surfels)
            out["eigenvalues"][row, :k] = spectrum.laplace_beltrami
            out["raw"][row, :k] = spectrum.eigenvalues
            out["status"].append("ok")
        except (ValueError, RuntimeError) as e:
            out["status"].append(str(e))
    scale = _np.ones(n)
    if normalize == "surface":
        scale = out["area"]
    elif normalize == "volume":
        scale = out["volume"] ** (2.0 / 3.0)
    for key in ("eigenvalues", "raw"):
        out[key] = out[key] * scale[:, None]
        if reweight:
            out[key][:, 1:] /= _np.arange(1, count)
    return out
