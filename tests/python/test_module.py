"""The Python module against the C++ library: same matrices, same spectra, no copies, clear
errors, the GIL released while computing (issue 11). Run by ctest (test python_module)."""
import gc
import os
import pathlib
import subprocess
import threading
import time

import numpy as np
import pytest
import scipy.io
import scipy.sparse
import scipy.sparse.linalg

import digilap


def flower_operator(h=0.02, **options):
    shape = digilap.Flower()
    digital = digilap.digitize(shape, h)
    contours = digilap.track_contours(digital)
    mu = digilap.measures(contours, digilap.ii_normals(digital, contours))
    return digilap.heat_laplacian(contours, mu, **options)


def test_csr_arrays_equal_the_cpp_export(tmp_path):
    op = flower_operator()
    paths = digilap.save_operator(op, str(tmp_path))
    # A contour operator gets its element table too (its overload is tried before the core's).
    assert [pathlib.Path(p).name for p in paths] == ["L.mtx", "A.mtx", "M.mtx", "elements.csv"]
    for name in ("L", "A", "M"):
        ours = getattr(op, name)
        assert isinstance(ours, scipy.sparse.csr_matrix)
        text = scipy.io.mmread(str(tmp_path / f"{name}.mtx")).tocsr()
        assert ours.shape == text.shape and ours.nnz == text.nnz
        assert (ours != text).nnz == 0, name  # bit for bit: the export writes round-trip digits
    # The app writes the same operator.
    app = os.environ.get("DIGILAP_APP_OPERATOR")
    if app:
        subprocess.run([app, "--quiet", "--shape", "flower", "--h", "0.02", "--format", "npz", "--out", str(tmp_path / "app")],
                       check=True, stdout=subprocess.DEVNULL)
        assert (scipy.sparse.load_npz(str(tmp_path / "app" / "L.npz")) != op.L).nnz == 0


def test_eigsh_on_the_pair_gives_the_library_eigenvalues():
    op = flower_operator()
    ours = digilap.smallest_eigenpairs(op, 8)
    values = np.sort(scipy.sparse.linalg.eigsh(-op.A, 8, op.M, sigma=-1e-8)[0])
    # Both solve -A x = lambda M x to about 1e-12 relative; 1e-8 leaves room for eigsh's own tolerance.
    assert np.allclose(values, ours.eigenvalues, rtol=0, atol=1e-8 * ours.eigenvalues[-1])
    vectors = ours.eigenvectors
    gram = vectors.T @ (op.M @ vectors)
    assert np.abs(gram - np.eye(8)).max() < 1e-9


def test_one_call_laplacian_in_the_robust_laplacian_convention():
    yy, xx = np.mgrid[0:80, 0:100]
    mask = (xx - 50) ** 2 / 40**2 + (yy - 40) ** 2 / 25**2 < 1
    L, M = digilap.laplacian(mask)
    assert isinstance(L, scipy.sparse.csr_matrix) and isinstance(M, scipy.sparse.csr_matrix)
    assert (L != L.T).nnz == 0  # symmetric bit for bit
    values = np.sort(scipy.sparse.linalg.eigsh(L, 11, M, sigma=-1e-8)[0])
    assert abs(values[0]) < 1e-8 * values[1]
    ratios = values[1:] / values[1]
    for m in range(1, 6):  # lambda_{2m-1} ~ lambda_{2m} ~ m^2 lambda_1 on a closed curve
        assert abs(ratios[2 * m - 1] - m * m) < 0.05 * m * m and abs(ratios[2 * m - 2] - m * m) < 0.05 * m * m
    L2, _ = digilap.laplacian(digilap.Circle(), h=0.05)
    assert L2.shape[0] > 0


def test_matrix_free_linear_operator_matches_the_matrix():
    shape = digilap.Flower()
    digital = digilap.digitize(shape, 0.01)
    contours = digilap.track_contours(digital)
    mu = digilap.measures(contours, digilap.ii_normals(digital, contours))
    op = digilap.heat_laplacian(contours, mu)
    free = digilap.MatrixFreeLaplacian(contours, mu)
    linear = free.as_linear_operator()
    v = np.random.default_rng(1).standard_normal(op.rows())
    scale = np.abs(op.L.diagonal()).max() * np.abs(v).max()
    assert np.abs(linear @ v - op.L @ v).max() <= 1e-10 * scale  # the transform's epsilon
    spectrum = free.smallest_eigenpairs(6)
    assert np.allclose(spectrum.eigenvalues, digilap.smallest_eigenpairs(op, 6).eigenvalues, atol=1e-7)


def test_arrays_are_views_on_the_operator_and_outlive_its_variable():
    op = flower_operator()
    L, mass, positions = op.L, op.mass, op.positions
    # Views: the same memory every time, not copies; read-only (the operator owns them).
    assert np.shares_memory(L.data, op.L.data) and np.shares_memory(L.indices, op.L.indices)
    assert np.shares_memory(mass, op.mass) and np.shares_memory(positions, op.positions)
    assert not mass.flags.writeable
    expected = L.sum(axis=1).copy(), mass.sum(), positions.copy()
    del op
    gc.collect()
    for _ in range(3):  # allocate to reuse freed memory, were it freed
        flower_operator(0.05)
    assert np.array_equal(L.sum(axis=1), expected[0])
    assert mass.sum() == expected[1] and np.array_equal(positions, expected[2])


def test_writing_into_a_view_says_how_to_get_a_writable_copy():
    op = flower_operator()
    L = op.L
    before = L.copy()
    writes = [lambda: L.eliminate_zeros(), lambda: L.__setitem__((0, 0), 3.0), lambda: L.setdiag(0.0),
              lambda: L.__imul__(2.0), lambda: L.__itruediv__(2.0)]
    for write in writes:
        with pytest.raises(digilap.Error, match=r"read-only view on the operator's memory.*op\.L\.copy\(\)"):
            write()
    assert (op.L != before).nnz == 0  # nothing was written into the operator
    # The copy is an ordinary writable matrix; reading works on the view as on any csr_matrix.
    writable = op.L.copy()
    writable.setdiag(0.0)
    writable.eliminate_zeros()
    assert writable.diagonal().max() == 0 and writable.nnz < L.nnz
    assert scipy.sparse.isspmatrix_csr(L) and np.allclose((2 * L) @ np.ones(L.shape[0]), 2 * (L @ np.ones(L.shape[0])))


def test_horse_spectrum_ratios_are_squares():
    path = os.path.join(os.environ.get("DIGILAP_TEST_DATA", ""), "horse.png")
    if not os.path.exists(path):
        pytest.skip("horse.png not found: run scripts/fetch_test_data.sh")
    digital = digilap.read_image(path)
    contours = digilap.filter_contours(digilap.track_contours(digital), largest_only=True)
    op = digilap.heat_laplacian(contours, digilap.measures(contours, digilap.ii_normals(digital, contours)))
    values = digilap.smallest_eigenpairs(op, 11).eigenvalues
    for m in range(1, 6):
        assert abs(values[2 * m] / values[1] - m * m) < 0.05 * m * m


@pytest.mark.parametrize("mask, exception, fragment", [
    (np.zeros((4, 4, 2), bool), ValueError, "expected a 2-D array"),
    (np.zeros((0, 5), bool), ValueError, "the array is empty"),
    (np.ones((5, 5), np.float64), TypeError, "expected a boolean or integer array"),
    (np.array(["a", "b"]).reshape(1, 2), TypeError, "expected a boolean or integer array"),
])
def test_bad_masks_are_refused_with_the_argument(mask, exception, fragment):
    with pytest.raises(exception, match=fragment):
        digilap.from_mask(mask)


def test_bad_values_raise_digilap_error_with_the_cpp_message():
    assert issubclass(digilap.Error, ValueError)
    with pytest.raises(digilap.Error, match="grid step h must be > 0 and finite"):
        digilap.digitize(digilap.Circle(), 0.0)
    with pytest.raises(digilap.Error, match="must be > 0"):
        digilap.from_mask(np.ones((5, 5), bool), h=-1.0)
    with pytest.raises(digilap.Error, match="above the memory limit"):
        flower_operator(0.02, k=1e6, memory_limit=1e6)  # a huge k: every pair, refused with its size
    with pytest.raises(digilap.Error, match="not finite"):
        digilap.Circle().closest_parameter(np.array([np.nan, 0.0]))
    with pytest.raises(digilap.Error, match="unknown parameter"):
        digilap.make_shape("flower:q=1")
    with pytest.raises(digilap.Error, match="Matrix Market"):
        digilap.load_matrix_market("/nonexistent.mtx")
    with pytest.raises(TypeError):
        digilap.digitize("circle", 0.1)
    free = digilap.MatrixFreeLaplacian(*_contours_and_mu())
    with pytest.raises(ValueError, match="expected"):
        free.matvec(np.zeros(3))


def _contours_and_mu():
    digital = digilap.digitize(digilap.Circle(), 0.05)
    contours = digilap.track_contours(digital)
    return contours, digilap.measures(contours, digilap.ii_normals(digital, contours))


def test_non_contiguous_masks_are_read_correctly():
    yy, xx = np.mgrid[0:60, 0:60]
    mask = (xx - 30) ** 2 + (yy - 30) ** 2 < 20**2
    wide = np.zeros((60, 120), bool)
    wide[:, ::2] = mask
    strided = wide[:, ::2]  # a view with a stride of 2: not contiguous
    assert not strided.flags.c_contiguous
    a = digilap.from_mask(strided, 0.1)
    b = digilap.from_mask(np.ascontiguousarray(mask), 0.1)
    assert a.pixel_count() == b.pixel_count() == mask.sum()
    assert a.contains(30, 59 - 30) and not a.contains(0, 0)  # row 0 at the top


def test_a_second_thread_runs_while_the_operator_is_assembled():
    digital = digilap.digitize(digilap.Flower(), 0.001)
    contours = digilap.track_contours(digital)
    mu = digilap.measures(contours, digilap.ii_normals(digital, contours))
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    worker = threading.Thread(target=count)
    worker.start()
    time.sleep(0.01)
    before = len(ticks)
    start = time.perf_counter()
    op = digilap.heat_laplacian(contours, mu, c_t=0.3, length_scale=1.0)  # ~0.1 s, GIL released
    elapsed = time.perf_counter() - start
    during = len([t for t in ticks if start <= t <= start + elapsed])
    done.set()
    worker.join()
    assert op.rows() > 0 and before > 0
    # The counter ticks every millisecond or so: without the GIL released it would not tick at all.
    assert elapsed > 0.02 and during >= min(5, elapsed / 0.004), (elapsed, during)


def test_polar_curve_from_python_callables():
    import math
    wavy = digilap.PolarCurve(lambda t: 1.5 + 0.2 * math.cos(3 * t), lambda t: -0.6 * math.sin(3 * t),
                              lambda t: -1.8 * math.cos(3 * t), name="wavy")
    same = digilap.Flower(1.5, 0.2, 3)
    assert wavy.name == "wavy"
    assert abs(wavy.length() - same.length()) < 1e-12 * same.length()
    a, b = digilap.digitize(wavy, 0.05), digilap.digitize(same, 0.05)
    assert a.pixel_count() == b.pixel_count()
    # A callable that raises, or returns what is not a number: refused when the curve is built,
    # with the callable's own message; the interpreter carries on.
    def broken(theta):
        raise RuntimeError("no radius here")
    with pytest.raises(digilap.Error, match="no radius here"):
        digilap.PolarCurve(broken, lambda t: 0.0, lambda t: 0.0)
    with pytest.raises(digilap.Error, match="d2r"):
        digilap.PolarCurve(lambda t: 1.0, lambda t: 0.0, lambda t: "curved")
    with pytest.raises(digilap.Error, match="must be > 0"):
        digilap.PolarCurve(lambda t: -1.0, lambda t: 0.0, lambda t: 0.0)


def test_measures_count_clamped_elements_under_both_names():
    # A box with a one-pixel spur: the spur's tip linel has an II normal orthogonal to it.
    mask = np.zeros((40, 60), np.uint8)
    mask[5:35, 10:50] = 1
    mask[18, 50:58] = 1
    digital = digilap.from_mask(mask, 0.05)
    contours = digilap.track_contours(digital)
    mu = digilap.measures(contours, digilap.ii_normals(digital, contours))
    assert mu.clamped == 1
    assert mu.clamped_linels == mu.clamped  # the earlier name (deprecated, issue 21)


def test_downstream_functions_and_options():
    op = flower_operator(0.05, distance="euclidean", placement="linels")
    assert op.rows() == op.mass.size
    with pytest.raises(ValueError, match="distance"):
        flower_operator(0.05, distance="manhattan")
    plain = flower_operator(0.05)
    noisy = np.cos(3 * plain.arclength / plain.contour_length[0] * 2 * np.pi) + 0.1 * np.random.default_rng(2).standard_normal(plain.rows())
    smooth = digilap.smooth_function(plain, noisy, 0.01, 2)
    assert abs(plain.mass @ smooth - plain.mass @ noisy) < 1e-12 * plain.mass.sum()  # heat kept
    assert np.abs(smooth).max() < np.abs(noisy).max()
    faired = digilap.smooth_positions(plain, tau=1e-3)
    assert faired.shape == (plain.rows(), 2)
    # The names shared with surfaces (issue 21); the earlier keyword warns and still works.
    shrunk = digilap.smooth_positions(plain, tau=1e-3, preserve_size=False)
    with pytest.warns(DeprecationWarning, match="preserve_size"):
        assert np.array_equal(digilap.smooth_positions(plain, tau=1e-3, preserve_area=False), shrunk)
    assert not np.array_equal(shrunk, faired)
    flow = digilap.HeatFlow(plain, 0.01)
    u = flow.advance(noisy, 5)
    assert abs(plain.mass @ u - plain.mass @ noisy) < 1e-12 * plain.mass.sum()
    rows = digilap.convergence_sweep(digilap.Circle(), "x2", [0.1, 0.05, 0.02], ["geodesic", "dec-naive"])
    assert [r["h"] for r in rows[::2]] == [0.1, 0.05, 0.02]
    geodesic = [r["relative_max_error"] for r in rows if r["operator"] == "geodesic"]
    assert geodesic[-1] < geodesic[0]  # it converges
    per_contour = digilap.smallest_eigenpairs_per_contour(plain, 5)
    assert len(per_contour) == 1 and np.allclose(per_contour[0].eigenvalues, digilap.smallest_eigenpairs(plain, 5).eigenvalues)


def test_each_contour_has_its_own_heat_time():
    """Geodesic contours do not interact: each gets t from its own length scale (issue 14)."""
    i, j = np.meshgrid(np.arange(160), np.arange(120))
    mask = (np.hypot(i - 60.3, j - 60.2) < 45) | (np.hypot(i - 140.2, j - 20.4) < 7)
    image = digilap.from_mask(mask)
    contours = digilap.track_contours(image)
    mu = digilap.measures(contours, digilap.ii_normals(image, contours))
    own = digilap.heat_laplacian(contours, mu)
    shared = digilap.heat_laplacian(contours, mu, per_contour_time=False)
    assert len(own.contour_t) == 2 and min(own.contour_t) < 0.5 * max(own.contour_t)
    assert shared.contour_t[0] == shared.contour_t[1] and own.t == max(own.contour_t)
    assert digilap.MatrixFreeLaplacian(contours, mu).contour_t == own.contour_t


def test_volumes_in_python(tmp_path):
    """NIfTI and .npy volumes through the same reader as the apps, with its refusals."""
    from digilap import surface
    data = pathlib.Path(__file__).resolve().parents[1] / "data"
    ball = surface.read_volume(str(data / "ball.nii.gz"))
    assert ball.h == 1.0 and ball.contains(8, 8, 8) and not ball.contains(0, 0, 0)
    mask = np.zeros((16, 16, 16), dtype=np.uint8)  # the same ball, (plane, row, column) = (z, y, x)
    k, j, i = np.indices(mask.shape)
    mask[(i - 7.5) ** 2 + (j - 7.5) ** 2 + (k - 7.5) ** 2 <= (16 / 3) ** 2] = 1
    np.save(tmp_path / "ball.npy", mask)
    assert surface.read_volume(str(tmp_path / "ball.npy"), h=1.0).voxel_count() == ball.voxel_count() == int(mask.sum())
    with pytest.raises(digilap.Error, match="anisotropic voxel spacing 1 x 1 x 2.5 mm"):
        surface.read_volume(str(data / "ball_anisotropic.nii"))


def test_surface_pipeline_in_python(tmp_path):
    """3D (SPEC §7) with the same conventions: the sphere's x^2 error and spectrum."""
    from digilap import surface
    sphere = surface.Sphere()
    centre = np.array([0.0123, -0.0371, 0.0217])
    sphere.set_pose(centre, np.eye(3))
    voxels = surface.digitize(sphere, 0.1)
    surfels = surface.extract_surfels(voxels)
    mu = surface.measures(surfels, surface.ii_normals(voxels, surfels, k_R=1.0, length_scale=1.0))
    op = surface.heat_laplacian(surfels, mu, c_t=0.03, length_scale=1.0, kernel="chord")  # SPEC §7's kernel
    assert isinstance(op.L, scipy.sparse.csr_matrix) and op.positions.shape == (len(surfels), 3)
    assert (op.A != op.A.T).nnz == 0
    p = np.array([sphere.closest_point(x) for x in op.positions])
    q = p - centre
    n = np.array([sphere.normal(x) for x in p])
    lap = 2 - 2 * n[:, 0] ** 2 - 4 * q[:, 0] * n[:, 0]
    error = np.abs(op.L @ q[:, 0] ** 2 - lap).max() / np.abs(lap).max()
    assert abs(100 * error - 27.8) < 0.1  # the reference implementation's figure (issue 13)
    assert surface.surface_names() == ["sphere", "ellipsoid", "torus"]
    assert surface.make_surface("sphere:r=2").name == "sphere" and abs(surface.make_surface("sphere:r=2").area() - 16 * np.pi) < 1e-9
    exact = surface.exact_normals(sphere, surfels)  # l measured as the II normals measure it
    assert exact.length_scale == surface.ii_normals(voxels, surfels).length_scale
    assert np.allclose(np.linalg.norm(exact.normals, axis=1), 1.0)
    assert np.all(np.einsum("ij,ij->i", exact.normals, q) > 0)  # outward
    spectrum = surface.smallest_eigenpairs(op, 4)
    assert np.allclose(spectrum.laplace_beltrami[1:4], 2.0, rtol=0.05)  # l = 1 at h = 0.1: 3.5% low measured
    faired = surface.smooth_positions(op, tau=5 * op.t)
    assert faired.shape == op.positions.shape
    radius = np.linalg.norm(faired - (op.mass @ faired) / op.mass.sum(), axis=1)
    assert radius.std() / radius.mean() < 0.3 * 0.0234  # the digital staircase's roundness, faired away
    vertices, faces = surface.save_ply(surfels, {"mu": mu.mu}, str(tmp_path / "s.ply"))
    assert faces == len(surfels) and vertices - faces == 2


def test_real_label_with_zero_areas_through_the_shared_core(tmp_path):
    """A real label (JHU white matter, 2 mm, label 6) has surfels of zero area: the spectrum is
    solved on the support of mu, zero-area rows get the average of their neighbours (L x = 0
    there), heat flow and export take the surface operator as they take a contour one (issues 21, 22)."""
    from digilap import surface
    data = pathlib.Path(__file__).resolve().parents[1] / "data"
    voxels = surface.read_volume(str(data / "JHU-WhiteMatter-labels-2mm.nii.gz"), label=6)
    surfels = surface.extract_surfels(voxels)
    mu = surface.measures(surfels, surface.ii_normals(voxels, surfels))
    op = surface.heat_laplacian(surfels, mu)
    assert isinstance(op, digilap.HeatOperator) and op.dimension == 2
    massless = op.massless_rows()
    assert len(massless) > 0 and np.all(op.mass[massless] == 0)
    spectrum = digilap.smallest_eigenpairs(op, 6)
    assert spectrum.massless == len(massless)
    x = spectrum.eigenvectors
    residual = op.A @ x + op.mass[:, None] * x * spectrum.eigenvalues[None, :]
    assert np.abs(residual).max() < 1e-7 * np.abs(op.A @ x).max()
    assert np.abs((op.L @ x)[massless]).max() < 1e-12 * np.abs(x).max() * np.abs(op.L.diagonal()[massless]).max()
    assert np.all(np.isfinite(spectrum.laplace_beltrami))
    flow = digilap.HeatFlow(op, op.t, digilap.TimeScheme.implicit_euler)
    u0 = (np.arange(op.rows()) < op.rows() // 5).astype(float)
    u = flow.advance(u0, 5)
    assert abs(op.mass @ u - op.mass @ u0) < 1e-12 * (op.mass @ u0) and u.min() >= -1e-14
    paths = digilap.save_operator(op, str(tmp_path))
    assert [pathlib.Path(p).name for p in paths] == ["L.mtx", "A.mtx", "M.mtx"]
    assert abs(scipy.io.mmread(paths[2]).diagonal() - op.mass).max() == 0
