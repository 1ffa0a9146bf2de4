"""digilap: a convergent Laplace-Beltrami operator on the boundary of digitized shapes.

The pipeline of the C++ library: shape or mask -> digital set -> contours -> normals ->
measures -> heat-kernel Laplacian, with NumPy arrays and scipy.sparse matrices. Curves (2D) are
here; surfaces of voxel sets (3D: volumes, segmentations) are in ``digilap.surface``. Both
operators are a ``HeatOperator``, which ``smallest_eigenpairs``, ``HeatFlow``,
``smooth_function`` and ``save_operator`` take alike.

Sign convention: ``heat_laplacian(...).L`` approximates +Laplace-Beltrami (negative
semidefinite, like libigl's cotmatrix) and ``A = M L`` is symmetric negative semidefinite.
``laplacian()`` returns ``(-A, M)``: a symmetric positive semidefinite "weak" Laplacian and a
diagonal mass matrix, the convention of robust_laplacian, so that
``scipy.sparse.linalg.eigsh(L, k, M, sigma=-1e-8)`` gives the smallest eigenpairs.

Errors of the library arrive as ``digilap.Error`` (a ``ValueError``) with the C++ message.
"""
import numpy as _np
import scipy.sparse.linalg as _linalg

from ._digilap import *  # noqa: F401,F403
from ._digilap import Error, MatrixFreeLaplacian, Shape, digitize, from_mask, heat_laplacian, ii_normals
from ._digilap import measures, track_contours

__all__ = [name for name in dir() if not name.startswith("_")] + ["laplacian"]


def laplacian(mask_or_shape, h=None, k_R=None, **options):
    """``L, M = laplacian(mask_or_shape, h=None, **options)``: the one-call operator.

    ``mask_or_shape``: a 2-D boolean mask (row 0 at the top, as scikit-image reads images) or a
    ``digilap.Shape``. ``h``: the grid step (default 1 / max(rows, columns) for a mask, 0.01 for
    a shape). ``k_R``: the II radius constant; other keyword arguments go to
    ``heat_laplacian`` (``t``, ``c_t``, ``k``, ``distance``, ``placement``, ...).

    Returns ``(L, M)`` as ``scipy.sparse.csr_matrix``: ``L = -A`` symmetric positive
    semidefinite, ``M = diag(mu)``; ``eigsh(L, k, M, sigma=-1e-8)`` works unchanged.
    """
    if isinstance(mask_or_shape, Shape):
        digital = digitize(mask_or_shape, 0.01 if h is None else h)
    else:
        digital = from_mask(_np.asarray(mask_or_shape), 0.0 if h is None else h)
    contours = track_contours(digital)
    if len(contours.contours) == 0:
        raise Error("laplacian: the mask has no foreground pixel, so no contour to build an operator on")
    normals = ii_normals(digital, contours) if k_R is None else ii_normals(digital, contours, k_R=k_R)
    op = heat_laplacian(contours, measures(contours, normals), **options)
    return -op.A, op.M


def _as_linear_operator(self):
    """L as a ``scipy.sparse.linalg.LinearOperator`` (for eigsh, cg, expm_multiply)."""
    n = self.rows()
    return _linalg.LinearOperator((n, n), matvec=self.matvec, dtype=_np.float64)


MatrixFreeLaplacian.as_linear_operator = _as_linear_operator

# The Python module digilap/surface.py, over the C++ submodule. Imported explicitly: the star
# import above already bound the name `surface` to the C++ submodule, and `from . import surface`
# would then keep that one instead of importing the file.
import importlib as _importlib  # noqa: E402

surface = _importlib.import_module(".surface", __name__)
