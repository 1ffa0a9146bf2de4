"""digilap against the pipeline its users run today (issue 22): marching cubes + linear FEM +
shift-invert eigsh, from tests/reference/mesh_fem.py, on a binary sphere (exact spectrum
l (l + 1), SPEC §7) and on real labels.

The reference is tested first against the exact spectrum, so that a comparison with it means
something; then digilap is held to beat it where the issue measured that it does.
"""
import pathlib
import sys

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "reference"))
mesh_fem = pytest.importorskip("mesh_fem")
pytest.importorskip("skimage")  # scripts/setup.sh installs python3-skimage: skipped only elsewhere

import digilap.surface  # noqa: E402

CENTRE = (0.0123, -0.0371, 0.0217)  # off the lattice, as SPEC §7's reference surfaces
EXACT = np.array([l * (l + 1.0) for l in range(5) for _ in range(2 * l + 1)])[:20]


def sphere_mask(h):
    c = CENTRE
    return mesh_fem.gauss_digitization(lambda x, y, z: (x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2 < 1, h, (-1.1, 1.1))


def worst_error(values):
    return np.max(np.abs(values[1:20] / EXACT[1:20] - 1))


def test_reference_fem_reproduces_the_known_staircase_bias_and_its_smoothing():
    """The unsmoothed marching-cubes mesh of a digitized sphere has ~8.8% too much area (the
    staircase), so its eigenvalues are ~8% low (measured at h = 0.1: area +8.5%, eigenvalues
    -7.3% on average); 10 Taubin iterations bring the worst of l = 1..4 to 1.6% (bound 2.5%, the
    issue's measurement at h = 0.025 was 1.6%). The first eigenvalue is 0 (closed surface)."""
    mask = sphere_mask(0.1)
    raw = mesh_fem.shape_dna(mask, 0.1, count=20, smoothing=0)
    assert 1.07 < raw["area"] / (4 * np.pi) < 1.10
    mean_low = np.mean(1 - raw["eigenvalues"][1:] / EXACT[1:])
    assert 0.05 < mean_low < 0.10
    smooth = mesh_fem.shape_dna(mask, 0.1, count=20, smoothing=10)
    assert abs(smooth["eigenvalues"][0]) < 1e-8
    assert worst_error(smooth["eigenvalues"]) < 0.025
    assert abs(smooth["volume"] / (4 * np.pi / 3) - 1) < 0.01


def test_digilap_beats_the_mesh_pipeline_on_the_sphere():
    """h = 0.05 (7,534 mesh vertices, ~7,500 surfels): digilap's worst error over l = 1..4 is
    0.61% (bound 1%), the raw mesh's 12.7% and Taubin-10's 2.3%: digilap must stay below both
    (the issue's table: digilap 0.34% at h = 0.025 against 1.6% for Taubin 10)."""
    h = 0.05
    mask = sphere_mask(h)
    ours = digilap.surface.shape_dna(mask.astype(np.uint8), labels=[1], count=20, h=h)
    assert ours["status"] == ["ok"]
    ours_error = worst_error(ours["eigenvalues"][0])
    raw = worst_error(mesh_fem.shape_dna(mask, h, count=20, smoothing=0)["eigenvalues"])
    taubin = worst_error(mesh_fem.shape_dna(mask, h, count=20, smoothing=10)["eigenvalues"])
    assert ours_error < 0.01
    assert ours_error < raw / 10 and ours_error < taubin
    assert abs(ours["area"][0] / (4 * np.pi) - 1) < 0.01  # the mesh's raw area is 8.8% off


def test_real_label_areas_and_volumes_agree_with_the_mesh():
    """On real labels (JHU 2 mm) no exact spectrum exists; area and volume are what both methods
    must agree on: the enclosed volume is exact for the voxels (8 mm^3 each) and the smoothed
    mesh's is within 15% of it (Taubin shrinks thin tracts); areas agree within 15% (measured:
    median +1.7%, extremes -13% .. +16% on the thinnest tracts, docs/accuracy.md)."""
    import gzip
    import struct

    atlas = pathlib.Path(__file__).resolve().parents[1] / "data" / "JHU-WhiteMatter-labels-2mm.nii.gz"
    raw = gzip.open(atlas).read()
    dims = struct.unpack_from("<8h", raw, 40)
    offset = int(struct.unpack_from("<f", raw, 108)[0])
    seg = np.frombuffer(raw, np.uint8, dims[1] * dims[2] * dims[3], offset).reshape(dims[1:4], order="F")
    for label in (1, 3, 5, 25):  # the larger structures, one component each
        mask = seg == label
        ours = digilap.surface.shape_dna(mask.astype(np.uint8), labels=[1], count=10, h=2.0, largest=True)
        theirs = mesh_fem.shape_dna(mask, 2.0, count=10, smoothing=10)
        assert ours["volume"][0] == 8.0 * mask.sum()
        assert abs(theirs["volume"] / ours["volume"][0] - 1) < 0.15
        assert abs(ours["area"][0] / theirs["area"] - 1) < 0.15
        assert np.all(np.diff(ours["eigenvalues"][0]) >= 0) and abs(ours["eigenvalues"][0][0]) < 1e-8


def torus_mesh(n_theta, n_phi, R=1.0, r=0.4):
    """A smooth parametric torus mesh (no staircase), two triangles per grid cell."""
    theta, phi = np.meshgrid(2 * np.pi * np.arange(n_theta) / n_theta, 2 * np.pi * np.arange(n_phi) / n_phi, indexing="ij")
    w = R + r * np.cos(phi)
    vertices = np.stack([w * np.cos(theta), w * np.sin(theta), r * np.sin(phi)], -1).reshape(-1, 3)
    a, b = np.meshgrid(np.arange(n_theta), np.arange(n_phi), indexing="ij")
    a, b = a.ravel(), b.ravel()
    at = lambda i, j: (i % n_theta) * n_phi + (j % n_phi)  # noqa: E731
    faces = np.concatenate([np.stack([at(a, b), at(a + 1, b), at(a + 1, b + 1)], 1),
                            np.stack([at(a, b), at(a + 1, b + 1), at(a, b + 1)], 1)])
    return vertices, faces


def test_torus_ground_truth_is_the_limit_of_a_smooth_mesh_fem():
    """mesh_fem.torus_spectrum (separation of variables, the benchmarks' exact torus spectrum)
    against the cotan FEM on smooth parametric meshes: second-order convergence (measured worst
    relative error over the first 49 non-zero eigenvalues 5.4e-3 on 200 x 80, 1.35e-3 on
    400 x 160: a ratio of 4.0), and its own discretization converged (4096 vs 8192 nodes: 6e-7)."""
    exact = mesh_fem.torus_spectrum(50)
    assert exact[0] == pytest.approx(0, abs=1e-9) and np.all(np.diff(exact) >= -1e-12)
    assert np.max(np.abs(mesh_fem.torus_spectrum(50, points=8192)[1:] / exact[1:] - 1)) < 2e-6
    errors = []
    for n_theta, n_phi in ((200, 80), (400, 160)):
        K, M = mesh_fem.fem_matrices(*torus_mesh(n_theta, n_phi))
        errors.append(np.max(np.abs(mesh_fem.smallest_eigenvalues(K, M, 50)[1:] / exact[1:] - 1)))
    assert errors[1] < 2e-3 and 3.5 < errors[0] / errors[1] < 4.5


def test_torus_ground_truth_agrees_with_the_library_one():
    """digilap.surface.torus_spectrum (C++: dense 256- and 512-node solves, Richardson) and the
    reference module's (sparse, 4,096 nodes, no extrapolation) are independent solvers of the same
    separated equation: within 1e-5 relative over the first 50 (each claims a few 1e-6 or better)."""
    exact = mesh_fem.torus_spectrum(50)
    library = np.asarray(digilap.surface.torus_spectrum(1.0, 0.4, 50))
    assert library[0] == 0
    assert np.max(np.abs(library[1:] / exact[1:] - 1)) < 1e-5
