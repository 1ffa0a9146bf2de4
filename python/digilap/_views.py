"""The operator's matrices as zero-copy SciPy views, with a message that names the fix.

``op.L``, ``op.A`` and ``op.M`` are ``scipy.sparse.csr_matrix`` over the C++ operator's own arrays
(no copy, kept alive by the operator), marked read-only so that NumPy refuses any write into the
operator's memory. NumPy's own words ("output array is read-only") do not say what to do, so the
in-place methods users call say it: take a writable copy with ``.copy()``.
"""
import scipy.sparse as _sparse

from ._digilap import Error


def _writable_copy_hint(error):
    return Error(f"{error}: this matrix is a read-only view on the operator's memory (zero-copy); "
                 "take a writable copy first, e.g. L = op.L.copy()")


class OperatorMatrix(_sparse.csr_matrix):
    """A read-only ``csr_matrix`` view on an operator's matrix; ``.copy()`` gives a writable one.

    Everything that reads (products, slicing, ``eigsh``, arithmetic that makes new matrices) works
    as on any ``csr_matrix``; the in-place methods below raise ``digilap.Error`` saying how to get a
    writable copy instead of NumPy's bare "read-only" ``ValueError``.
    """

    def _in_place(self, method, *args, **kwargs):
        try:
            return method(self, *args, **kwargs)
        except ValueError as error:
            if "read-only" not in str(error):
                raise
            raise _writable_copy_hint(error) from None

    def eliminate_zeros(self):
        return self._in_place(_sparse.csr_matrix.eliminate_zeros)

    def setdiag(self, values, k=0):
        return self._in_place(_sparse.csr_matrix.setdiag, values, k)

    def __setitem__(self, key, value):
        return self._in_place(_sparse.csr_matrix.__setitem__, key, value)

    def __imul__(self, other):
        return self._in_place(_sparse.csr_matrix.__imul__, other)

    def __itruediv__(self, other):
        return self._in_place(_sparse.csr_matrix.__itruediv__, other)
