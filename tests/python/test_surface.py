"""digilap.surface from NumPy: volumes read in place in nibabel's convention, the real-label
lattice symmetries, the ShapeDNA table and the heat kernel signature (issues 21, 22)."""
import gzip
import pathlib
import struct

import numpy as np
import pytest

import digilap
import digilap.surface as surface  # an importable module, not only an attribute

DATA = pathlib.Path(__file__).resolve().parents[1] / "data"
ATLAS = DATA / "JHU-WhiteMatter-labels-2mm.nii.gz"


def atlas_array():
    """The atlas as array[i, j, k] (NIfTI's x fastest), read from the NIfTI-1 bytes (no nibabel needed)."""
    raw = gzip.open(ATLAS).read()
    dims = struct.unpack_from("<8h", raw, 40)
    offset = int(struct.unpack_from("<f", raw, 108)[0])
    assert dims[0] == 3 and struct.unpack_from("<h", raw, 70)[0] == 2  # 3-D uint8
    n = dims[1] * dims[2] * dims[3]
    return np.frombuffer(raw, dtype=np.uint8, count=n, offset=offset).reshape(dims[1:4], order="F")


def spectrum_of(volume, count=8, **kw):
    voxels = volume if isinstance(volume, surface.VoxelSet) else surface.from_mask(volume, **kw)
    surfels = surface.filter_surfels(voxels, surface.extract_surfels(voxels), largest_only=True)
    op = surface.heat_laplacian(surfels, surface.measures(surfels, surface.ii_normals(voxels, surfels)))
    return op, digilap.smallest_eigenpairs(op, count)


def test_from_mask_is_read_volume_in_nibabels_convention():
    """label == 6 of the array as nibabel gives it, and read_volume(label=6), are the same voxels:
    the same operator to the bit, in place for C, Fortran and strided views."""
    seg = atlas_array()
    by_file = surface.read_volume(str(ATLAS), label=6)
    by_array = surface.from_mask(seg, h=2.0, label=6)
    assert by_array.voxel_count() == by_file.voxel_count() == int((seg == 6).sum())
    a, b = spectrum_of(by_file)[0], spectrum_of(by_array)[0]
    assert a.rows() == b.rows() and (a.L != b.L).nnz == 0 and (a.A != b.A).nnz == 0
    c_order = np.ascontiguousarray(seg == 6)
    for mask in (c_order, np.asfortranarray(c_order), np.pad(c_order, 1)[1:-1, 1:-1, 1:-1]):
        v = surface.from_mask(mask, h=2.0)
        assert v.voxel_count() == by_file.voxel_count()
        assert all(v.contains(int(i), int(j), int(k)) for i, j, k in np.argwhere(c_order)[::37])
    with pytest.raises(ValueError, match="3-D"):
        surface.from_mask(np.zeros((4, 4), bool))
    with pytest.raises(TypeError, match="boolean or integer"):
        surface.from_mask(np.zeros((4, 4, 4), np.float32))


def test_real_label_lattice_symmetries_and_padding():
    """A real label (JHU 2 mm, label 3): axes permuted and flipped give the same eigenvalues
    (1e-8 relative: the solver's tolerance is 1e-10 on the Ritz values; the surfel order, hence
    LOBPCG's start, changes); zero padding changes nothing (1e-12: the same surfels shifted by
    whole voxels)."""
    mask = atlas_array() == 3
    ref = spectrum_of(mask, h=2.0)[1].eigenvalues
    for moved in (mask.transpose(1, 0, 2), mask[::-1, :, ::-1], mask.transpose(2, 1, 0)[:, ::-1, :]):
        values = spectrum_of(np.ascontiguousarray(moved), h=2.0)[1].eigenvalues
        assert np.allclose(values[1:], ref[1:], rtol=1e-8, atol=0)
    padded = spectrum_of(np.pad(mask, ((3, 5), (0, 7), (2, 2))), h=2.0)[1].eigenvalues
    assert np.allclose(padded[1:], ref[1:], rtol=1e-12, atol=0)


def test_shape_dna_table_and_failures():
    """Every structure a row, a failing one NaN with its reason; normalizations as BrainPrint's."""
    seg = atlas_array()
    table = surface.shape_dna(seg, labels=[6, 0, 200], count=10, h=2.0)
    assert list(table["labels"]) == [6, 0, 200]
    assert table["status"][0] == "ok" and "background" in table["status"][1] and "200" in table["status"][2]
    assert np.isnan(table["eigenvalues"][1:]).all() and np.isfinite(table["eigenvalues"][0]).all()
    op, s = spectrum_of(seg, h=2.0, label=6, count=10)
    assert np.allclose(table["eigenvalues"][0], s.laplace_beltrami, rtol=1e-12)
    assert table["volume"][0] == 8.0 * int((seg == 6).sum())  # 2 mm voxels, one surface, no cavity
    scaled = surface.shape_dna(seg, labels=[6], count=10, h=2.0, normalize="volume", reweight=True)
    expected = s.laplace_beltrami * table["volume"][0] ** (2 / 3)
    expected[1:] /= np.arange(1, 10)
    assert np.allclose(scaled["eigenvalues"][0], expected, rtol=1e-12)


def test_heat_kernel_signature():
    """sum_x mu_x HKS(x, tau) = sum_k exp(-lambda_k tau) for M-orthonormal eigenvectors; the
    default times span 4 ln 10 / lambda_last to 4 ln 10 / lambda_1."""
    op, s = spectrum_of(atlas_array() == 3, h=2.0, count=12)
    times = digilap.heat_kernel_signature_times(s, 4)
    lam = s.laplace_beltrami
    assert np.isclose(times[0], 4 * np.log(10) / lam[-1]) and np.isclose(times[-1], 4 * np.log(10) / lam[1])
    hks = digilap.heat_kernel_signature(s, times)
    assert hks.shape == (op.rows(), 4) and (hks >= 0).all()
    for c, tau in enumerate(times):
        assert np.isclose(op.mass @ hks[:, c], np.exp(-np.maximum(lam, 0) * tau).sum(), rtol=1e-10)
    with pytest.raises(digilap.Error):
        digilap.heat_kernel_signature(s, [0.0])
