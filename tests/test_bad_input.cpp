// Every input a user can give gets a correct answer or a clear error: one row per case, run
// through the apps as a user would, checking the exit code and a fragment of the message.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>

namespace {

struct Case {
  const char* name;
  const char* app;       // "operator", "spectrum", "heat", "convergence"
  std::string args;      // {dir} stands for the scratch directory
  std::string file;      // written to {dir}/<name>.img (or .nii, .npy) when the arguments name that file
  bool succeeds;         // expected exit code 0 (else non-zero)
  const char* fragment;  // expected in the output
};

std::string app_path(const std::string& app) {
  if (app == "operator") return DIGILAP_APP_OPERATOR;
  if (app == "spectrum") return DIGILAP_APP_SPECTRUM;
  if (app == "heat") return DIGILAP_APP_HEAT;
  return DIGILAP_APP_CONVERGENCE;
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
  return s;
}

// The first `bytes` bytes of a committed file (a truncated copy).
std::string file_prefix(const std::string& path, std::size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  std::string s(bytes, '\0');
  in.read(s.data(), static_cast<std::streamsize>(bytes));
  s.resize(static_cast<std::size_t>(in.gcount()));
  return s;
}

// A uint8 .npy volume of shape (n, n, n) filled with `value` (only its header when value < 0).
std::string npy_cube(int n, int value) {
  const std::string dims = std::to_string(n);
  std::string dict = "{'descr': '|u1', 'fortran_order': False, 'shape': (" + dims + ", " + dims + ", " + dims + "), }";
  dict.append(117 - dict.size(), ' ');
  const std::string header = std::string("\x93NUMPY\x01\x00\x76\x00", 10) + dict + "\n";
  return value < 0 ? header : header + std::string(static_cast<std::size_t>(n) * n * n, static_cast<char>(value));
}

// A 26^3 uint8 segmentation ([z, y, x]): label 1 one voxel, label 2 a thousand one-voxel
// components (x, y, z even in [4, 22]), label 3 a 3^3 block touching the volume's border.
std::string npy_labels() {
  const int n = 26;
  std::string dict = "{'descr': '|u1', 'fortran_order': False, 'shape': (26, 26, 26), }";
  dict.append(117 - dict.size(), ' ');
  std::string data(static_cast<std::size_t>(n) * n * n, '\0');
  auto at = [&](int x, int y, int z) -> char& { return data[static_cast<std::size_t>((z * n + y) * n + x)]; };
  at(13, 13, 1) = 1;
  for (int z = 4; z <= 22; z += 2)
    for (int y = 4; y <= 22; y += 2)
      for (int x = 4; x <= 22; x += 2) at(x, y, z) = 2;
  for (int z = 23; z < n; ++z)
    for (int y = 23; y < n; ++y)
      for (int x = 23; x < n; ++x) at(x, y, z) = 3;
  return std::string("\x93NUMPY\x01\x00\x76\x00", 10) + dict + "\n" + data;
}

// A .npy of shape (6, 6, 6) and dtype `descr` whose 2^3 centre voxels hold `inside` (the bytes of
// one element, in the file's byte order) and the others zero; `padding` extra characters of a
// string in the header (NumPy keeps any dict; a long one crashed a recursive regex).
std::string npy_typed(const std::string& descr, const std::string& inside, std::size_t padding = 0) {
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (6, 6, 6), ";
  if (padding > 0) dict += "'note': '" + std::string(padding, 'a') + "', ";
  dict += "}";
  const std::size_t length = ((10 + dict.size() + 1 + 63) / 64) * 64 - 10;  // data aligned to 64
  dict.append(length - 1 - dict.size(), ' ');
  dict += "\n";
  const char version = length > 65535 ? 2 : 1;
  std::string head = std::string("\x93NUMPY", 6) + version + '\0';
  for (int b = 0; b < (version == 2 ? 4 : 2); ++b) head += static_cast<char>((length >> (8 * b)) & 0xff);
  std::string data;
  for (int z = 0; z < 6; ++z)
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 6; ++x) {
        const bool centre = x >= 2 && x < 4 && y >= 2 && y < 4 && z >= 2 && z < 4;
        data += centre ? inside : std::string(inside.size(), '\0');
      }
  return head + dict + data;
}

std::string p5(int w, int h, int maxval, int value) {
  std::string s = "P5\n" + std::to_string(w) + " " + std::to_string(h) + "\n" + std::to_string(maxval) + "\n";
  return s + std::string(static_cast<std::size_t>(w) * h, static_cast<char>(value));
}

const std::vector<Case> kCases = {
    {"missing_file", "operator", "--image {dir}/does_not_exist.pgm", "", false, "cannot open the file"},
    {"empty_file", "operator", "--image {dir}/empty_file.img", "", false, "the file is empty"},
    {"truncated_raster", "operator", "--image {dir}/truncated_raster.img", "P5\n10 10\n255\n" + std::string(50, '\0'), false, "truncated: 50 of 100"},
    {"truncated_header", "operator", "--image {dir}/truncated_header.img", "P2\n10", false, "truncated: no height"},
    {"truncated_ascii", "operator", "--image {dir}/truncated_ascii.img", "P2 3 3 255 0 0 0 0", false, "truncated: 4 of 9 pixels"},
    {"wrong_magic", "operator", "--image {dir}/wrong_magic.img", "GIF89a....", false, "unknown format"},
    {"png_garbage", "operator", "--image {dir}/png_garbage.img", std::string("\x89PNG\r\n\x1a\n", 8) + "garbage", false, "not a readable PNG"},
    {"width_zero", "operator", "--image {dir}/width_zero.img", "P2 0 3 255\n", false, "width and height must be > 0"},
    {"width_negative", "operator", "--image {dir}/width_negative.img", "P2 -4 3 255\n", false, "width is negative"},
    {"size_overflow", "operator", "--image {dir}/size_overflow.img", "P5 4294967296 4294967296 255\n", false, "above the limit"},
    {"size_over_limit", "operator", "--image {dir}/size_over_limit.img", "P5 30000 30000 255\n", false, "above the limit"},
    {"maxval_zero", "operator", "--image {dir}/maxval_zero.img", "P2 2 2 0\n0 0 0 0\n", false, "maxval must be in [1, 65535]"},
    {"maxval_too_large", "operator", "--image {dir}/maxval_too_large.img", "P2 2 2 70000\n0 0 0 0\n", false, "maxval must be in [1, 65535]"},
    {"value_above_maxval", "operator", "--image {dir}/value_above_maxval.img", "P2 2 2 10\n0 11 0 0\n", false, "above maxval"},
    {"pbm_bad_digit", "operator", "--image {dir}/pbm_bad_digit.img", "P1 2 2\n0 1 2 0\n", false, "must be 0 or 1"},
    {"all_background", "operator", "--image {dir}/all_background.img", p5(20, 20, 255, 255), false, "no foreground pixel"},
    {"all_foreground", "operator", "--image {dir}/all_foreground.img --out {dir}/out", p5(20, 20, 255, 0), true, "1 contour(s), N = 80"},
    {"single_pixel_disk_too_wide", "operator", "--image {dir}/single_pixel_disk_too_wide.img --min-linels 0 --kR 4", "P1 3 3 0 0 0 0 1 0 0 0 0", false, "exceeds the whole set"},
    {"single_pixel_dropped", "operator", "--image {dir}/single_pixel_dropped.img", "P1 3 3 0 0 0 0 1 0 0 0 0", false, "no contour left"},
    {"single_pixel_kept", "operator", "--image {dir}/single_pixel_kept.img --min-linels 0 --kR 0.5 --out {dir}/out", "P1 3 3 0 0 0 0 1 0 0 0 0", true, "N = 4 elements"},
    {"single_pixel_spectrum", "spectrum", "--image {dir}/single_pixel_spectrum.img --min-linels 0 --kR 0.5 --out {dir}/out", "P1 3 3 0 0 0 0 1 0 0 0 0", false, "count must be in [1, 3]"},
    {"exact_normals_on_image", "operator", "--image {dir}/exact_normals_on_image.img --normals exact", p5(9, 9, 255, 0), false, "needs a reference shape"},
    {"h_zero", "operator", "--h 0", "", false, "must be > 0 and finite"},
    {"h_negative", "operator", "--h -0.1", "", false, "must be > 0 and finite"},
    {"h_nan", "operator", "--h nan", "", false, "must be > 0 and finite"},
    {"h_infinite", "operator", "--h inf", "", false, "must be > 0 and finite"},
    // Steps whose areas or eigenvalues overflow or vanish in double (SPEC: any unit, but finite results).
    {"h_vanishing", "operator", "--h 1e-40", "", false, "grid step h = 1e-40 is outside [1e-30, 1e+30]"},
    {"volume_h_vast", "spectrum", "--volume {data}/../fuzz/volume_corpus/ball_u1.npy --h 1e40", "", false, "is outside [1e-30, 1e+30]"},
    {"h_too_fine", "operator", "--h 1e-12", "", false, "too fine"},
    {"h_not_a_number", "operator", "--h abc", "", false, "must be a number"},
    {"t_negative", "operator", "--t -1", "", false, "t must be > 0 and finite"},
    {"t_nan", "operator", "--t nan", "", false, "t must be > 0 and finite"},
    {"k_zero", "operator", "--k 0", "", false, "must be > 0 and finite"},
    {"k_negative", "spectrum", "--k -3", "", false, "must be > 0 and finite"},
    {"ct_zero", "heat", "--ct 0", "", false, "must be > 0 and finite"},
    {"kR_covers_shape", "operator", "--shape circle --h 0.1 --kR 100", "", false, "exceeds the whole set"},
    {"window_wider_than_contour", "operator", "--shape circle --h 0.1 --t 100 --out {dir}/out", "", true, "nnz(L) = 5"},
    {"unknown_shape", "operator", "--shape square", "", false, "unknown shape 'square'"},
    {"unknown_shape_convergence", "convergence", "--shape square", "", false, "unknown shape 'square'"},
    {"unknown_function", "convergence", "--function sin", "", false, "unknown test function 'sin'"},
    {"convergence_one_step", "convergence", "--h 0.1 --out {dir}/conv", "", true, "one step: no slope"},
    {"heat_huge_step_conserves", "heat", "--shape circle --h 0.1 --tau 1e15 --steps 1 --snapshots 2 --scheme euler --initial bump --length-scale 1 --kR 1 --ct 0.03 --out {dir}/heat", "", true, "| 1e+15 | 0.00000000 | 0.00000000 | inf | 0.76193311"},
    {"unknown_operator", "convergence", "--operators cotan", "", false, "unknown operator 'cotan'"},
    {"bad_distance", "operator", "--distance manhattan", "", false, "manhattan"},
    {"memory_limit", "operator", "--memory-limit 1000", "", false, "above the memory limit"},
    {"count_too_large", "spectrum", "--shape circle --h 0.5 --count 50", "", false, "count must be in [1,"},
    {"count_too_large_matrix_free", "spectrum", "--shape circle --h 0.5 --count 50 --matrix-free", "", false, "count must be in [1,"},
    {"matrix_free_spectrum", "spectrum", "--shape circle --h 0.02 --matrix-free --quiet --out {dir}/mf", "", true, "matrix-free: "},
    {"matrix_free_memory", "spectrum", "--matrix-free --count 20 --memory-limit 1e6", "", false, "above the memory limit"},
    {"tolerance_zero", "spectrum", "--shape sphere --h 0.1 --tolerance 0", "", false, "tolerance must be in [1e-14, 1)"},
    {"tolerance_too_loose", "spectrum", "--shape sphere --h 0.1 --tolerance 0.5", "", false, "not in range"},
    {"tolerance_loose", "spectrum", "--shape sphere --h 0.1 --count 10 --tolerance 1e-6 --draw 0 --out {dir}/tol", "", true, "# eigen-solver: "},
    {"ten_squares_per_contour", "spectrum", "--image {data}/ten_squares.pbm --h 0.02 --t 4e-4 --kR 0.3 --per-contour --count 5 --out {dir}/pc", "", true, "## contour 9: 24 rows"},
    {"ten_squares_per_contour_matrix_free", "spectrum", "--image {data}/ten_squares.pbm --h 0.02 --t 4e-4 --kR 0.3 --per-contour --matrix-free --out {dir}/pcmf", "", true, "## contour 9: 24 rows"},
    {"ten_squares_joint_says_they_mix", "spectrum", "--image {data}/ten_squares.pbm --h 0.02 --t 4e-4 --kR 0.3 --out {dir}/joint", "", true, "use --per-contour"},
    {"per_contour_euclidean", "spectrum", "--image {data}/ten_squares.pbm --h 0.02 --t 4e-4 --kR 0.3 --per-contour --distance euclidean --out {dir}/pce", "", false, "interacts with another one"},
    {"matrix_free_cut_below_spacing", "spectrum", "--shape circle --h 0.1 --count 3 --t 1e-6 --matrix-free --out {dir}/mfcut", "", false, "does not reach from every element to the next"},
    {"matrix_free_tiny_t_huge_k", "spectrum", "--shape circle --h 0.1 --count 3 --t 1e-16 --k 1e9 --matrix-free --memory-limit 1e6 --out {dir}/mftiny", "", true, "matrix-free: "},
    {"t_prefactor_overflows", "spectrum", "--shape circle --h 0.1 --t 1e-300 --matrix-free", "", false, "is too small: the kernel's prefactor"},
    {"spectrum_above_one_over_t", "spectrum", "--shape circle --h 0.1 --count 75 --out {dir}/above", "", true, "have no Laplace-Beltrami estimate"},
    {"unknown_format", "operator", "--shape circle --h 0.1 --format hdf5", "", false, "--format"},
    {"npz_export", "operator", "--shape circle --h 0.1 --format npz --out {dir}/npz", "", true, "L.npz"},
    {"shape_with_parameters", "operator", "--shape flower:R=1.5,v=0.3,k=4 --rotate 30 --centre 0.1,-0.2 --h 0.05 --out {dir}/shp", "", true, "shape flower, h = 0.05"},
    {"shape_unknown_key", "operator", "--shape flower:q=1", "", false, "unknown parameter 'q' (flower takes R, v, k, phase"},
    {"shape_bad_value", "spectrum", "--shape circle:r=abc", "", false, "r = 'abc' is not a finite number"},
    {"shape_through_its_centre", "heat", "--shape flower:R=1,v=2", "", false, "need R > |v|"},
    {"shape_radius_zero", "operator", "--shape circle:r=0", "", false, "radius must be > 0"},
    {"shape_petals_not_whole", "convergence", "--shape accflower:k=2.5", "", false, "k must be a whole number"},
    {"shape_key_twice", "operator", "--shape ellipse:a=3,a=2", "", false, "given twice"},
    {"shape_too_fine_to_sample", "operator", "--shape flower:k=20000", "", false, "the tangent turns by"},
    {"rotate_not_finite", "operator", "--shape circle --rotate inf", "", false, "--rotate"},
    {"surface_spectrum", "spectrum", "--shape sphere --h 0.2 --count 10 --out {dir}/sphere", "", true, "surfels.ply"},
    {"surface_torus_ring_too_small", "spectrum", "--shape torus:R=0.3,r=1", "", false, "need R > r > 0"},
    {"surface_unknown_key", "spectrum", "--shape ellipsoid:d=2", "", false, "unknown parameter 'd'"},
    {"surface_matrix_free", "spectrum", "--shape sphere --h 0.2 --count 5 --matrix-free --out {dir}/mf", "", true, ", matrix-free"},
    {"surface_per_contour", "spectrum", "--shape sphere --per-contour", "", false, "--per-contour is for curves"},
    // Options a surface or a volume does not use are refused with the reason, never ignored (issue 25).
    {"surface_distance", "spectrum", "--shape sphere --h 0.2 --distance euclidean", "", false, "--distance is for curves: on a surface"},
    {"volume_placement", "heat", "--volume {data}/../fuzz/volume_corpus/ball_u1.npy --placement linels", "", false, "--placement is for curves"},
    {"volume_invert", "operator", "--volume {data}/../fuzz/volume_corpus/ball_u1.npy --invert", "", false, "--invert is for images"},
    {"volume_exact_normals", "spectrum", "--volume {data}/../fuzz/volume_corpus/ball_u1.npy --normals exact", "", false, "a volume has no exact surface"},
    {"curve_couple_surfaces", "spectrum", "--shape flower --couple-surfaces", "", false, "--couple-surfaces is for surfaces"},
    // --normals exact on a reference surface is applied: the area is the exact normals' (SPEC 7).
    {"surface_exact_normals", "spectrum", "--shape sphere --h 0.2 --count 5 --normals exact --out {dir}/exact", "", true, ", exact normals"},
    // The eigen-solver's own memory is estimated first (issue 25: 2.9 GB unannounced for --count 5000).
    {"spectrum_memory", "spectrum", "--shape sphere --h 0.1 --count 400 --memory-limit 2e7 --assembled", "", false, "GB (factorization and Lanczos) or 0.048"},
    {"spectrum_memory_matrix_free", "spectrum", "--shape sphere --h 0.1 --count 400 --memory-limit 2e7", "", false, "LOBPCG's blocks would take about 0.048"},
    {"assembled_and_matrix_free", "spectrum", "--shape sphere --h 0.2 --assembled --matrix-free", "", false, "--assembled and --matrix-free: give one"},
    {"assembled_on_curves", "spectrum", "--h 0.05 --assembled", "", false, "--assembled is for surfaces and volumes"},
    {"surface_kernel_on_curves", "operator", "--h 0.05 --surface-kernel chord", "", false, "--surface-kernel is for surfaces and volumes"},
    {"surface_kernel_unknown", "operator", "--shape sphere --h 0.2 --surface-kernel geodesic", "", false, "--surface-kernel"},
    {"surface_count_too_large", "spectrum", "--shape sphere --h 0.5 --count 500", "", false, "count must be in [1,"},
    {"volume_spectrum", "spectrum", "--volume {data}/../fuzz/volume_corpus/ball_u1.npy --count 5 --out {dir}/vol", "", true, "ball_u1.npy, h = 1,"},
    {"volume_label_absent", "spectrum", "--volume {data}/../fuzz/volume_corpus/labels_u2.npy --label 9", "", false, "no voxel has the label 9"},
    {"volume_missing", "spectrum", "--volume {dir}/none.npy", "", false, "cannot open the file"},
    {"volume_truncated", "spectrum", "--volume {dir}/volume_truncated.npy", std::string("\x93NUMPY\x01\x00\x40\x00", 10) + "{'descr': '|u1', 'fortran_order': False, 'shape': (9, 9, 9), }" + std::string(8, ' ') + "\n" + std::string(5, '\1'), false, "truncated: the data holds"},
    {"volume_wrong_dtype", "spectrum", "--volume {dir}/volume_wrong_dtype.npy", std::string("\x93NUMPY\x01\x00\x40\x00", 10) + "{'descr': '<c8', 'fortran_order': False, 'shape': (1, 1, 1), }" + std::string(8, ' ') + "\n" + std::string(8, '\0'), false, "dtype '<c8' is not supported"},
    {"volume_nifti_spectrum", "spectrum", "--volume {data}/ball.nii.gz --count 5 --out {dir}/nii", "", true, "ball.nii.gz, h = 1"},
    {"volume_nifti_anisotropic", "spectrum", "--volume {data}/ball_anisotropic.nii", "", false, "anisotropic voxel spacing 1 x 1 x 2.5 mm: the operator assumes cubic voxels"},
    {"volume_nifti_truncated", "operator", "--volume {dir}/volume_nifti_truncated.nii", file_prefix(DIGILAP_SOURCE_DATA "/../fuzz/volume_corpus/ball_u1.nii", 600), false, "truncated: the data needs 512 bytes from byte 352, the file has 600"},
    {"volume_nifti_corrupt", "operator", "--volume {dir}/volume_nifti_corrupt.nii", "GIF89a" + std::string(400, 'x'), false, "not a NIfTI file"},
    {"volume_unknown_extension", "operator", "--volume {data}/ten_squares.pbm", "", false, "unknown extension (.npy, .nii or .nii.gz)"},
    {"volume_npy_int32", "spectrum", "--volume {dir}/volume_npy_int32.npy --min-size 0 --count 3 --out {dir}/i4", npy_typed("<i4", std::string("\x01\0\0\0", 4)), true, "N = 24 surfels"},
    {"volume_npy_int64_label", "spectrum", "--volume {dir}/volume_npy_int64_label.npy --label 300 --min-size 0 --count 3 --out {dir}/i8", npy_typed("<i8", std::string("\x2c\x01\0\0\0\0\0\0", 8)), true, "N = 24 surfels"},
    {"volume_npy_float64", "spectrum", "--volume {dir}/volume_npy_float64.npy --threshold 0.5 --min-size 0 --count 3 --out {dir}/f8", npy_typed("<f8", std::string("\0\0\0\0\0\0\xf0\x3f", 8)), true, "N = 24 surfels"},
    {"volume_npy_float32_big_endian", "spectrum", "--volume {dir}/volume_npy_float32_big_endian.npy --min-size 0 --count 3 --out {dir}/f4", npy_typed(">f4", std::string("\x3f\x80\0\0", 4)), true, "N = 24 surfels"},
    {"volume_npy_negative_int16", "spectrum", "--volume {dir}/volume_npy_negative_int16.npy --min-size 0", npy_typed("<i2", std::string("\xff\xff", 2)), false, "no voxel reaches the threshold"},
    {"volume_npy_nan", "spectrum", "--volume {dir}/volume_npy_nan.npy --min-size 0", npy_typed("<f4", std::string("\0\0\xc0\x7f", 4)), false, "voxel (2, 2, 2) is NaN"},
    {"volume_npy_float16", "spectrum", "--volume {dir}/volume_npy_float16.npy", npy_typed("<f2", std::string("\0\x3c", 2)), false, "dtype '<f2' is not supported"},
    {"volume_npy_long_header_string", "spectrum", "--volume {dir}/volume_npy_long_header_string.npy --min-size 0 --count 3 --out {dir}/long", npy_typed("|u1", "\x01", 40000), true, "N = 24 surfels"},
    {"volume_npy_default_h_is_the_voxel", "spectrum", "--volume {dir}/volume_npy_default_h_is_the_voxel.npy --min-size 0 --count 3 --out {dir}/u1", npy_typed("|u1", "\x01"), true, "h = 1, N = 24 surfels"},
    {"memory_limit_nan", "operator", "--shape circle --memory-limit nan", "", false, "--memory-limit must be a number of bytes > 0"},
    {"memory_limit_negative", "spectrum", "--shape sphere --memory-limit -5", "", false, "--memory-limit must be a number of bytes > 0"},
    {"volume_empty", "spectrum", "--volume {dir}/volume_empty.npy", npy_cube(6, 0), false, "no voxel reaches the threshold"},
    {"volume_all_foreground", "spectrum", "--volume {dir}/volume_all_foreground.npy --count 3 --out {dir}/full", npy_cube(6, 1), true, "volume_all_foreground.npy, h = 1,"},
    {"volume_single_voxel_dropped", "operator", "--volume {data}/../fuzz/volume_corpus/single_voxel.npy", "", false, "every surface has fewer than 8 surfels: lower --min-size"},
    {"volume_single_voxel_kept", "operator", "--volume {data}/../fuzz/volume_corpus/single_voxel.npy --min-linels 0 --out {dir}/one", "", true, "N = 6 surfels, nnz(L) = 36, area 6"},
    {"volume_size_above_limit", "operator", "--volume {dir}/volume_size_above_limit.npy", npy_cube(2000, -1), false, "voxels are above the limit"},
    // Issue 21: an explicit --kR 2 on a surface is 2 (it was taken for the unset default, 1):
    // R = 2 h^(1/3) with l = 1 is 0.928318 at h = 0.1.
    {"surface_explicit_kR_2", "operator", "--shape sphere --h 0.1 --kR 2 --length-scale 1 --out {dir}/kR2", "", true, "II radius R = 0.928318"},
    // The default is k_R from l / h: h^(1/3) = 0.464 (k_R = 1) < l / 2 = 0.5 < 1.5 h^(1/3), so R = l / 2.
    {"surface_default_kR_adaptive", "operator", "--shape sphere --h 0.1 --length-scale 1 --out {dir}/kR1", "", true, "II radius R = 0.5,"},
    {"volume_min_size_alias", "operator", "--volume {data}/../fuzz/volume_corpus/single_voxel.npy --min-size 0 --out {dir}/one6", "", true, "N = 6 surfels"},
    // Issue 22: a real label whose thin parts give surfels of zero area (II normal orthogonal to
    // the surfel) has a spectrum, solved on the support of mu (JHU white-matter atlas, 2 mm, label 6).
    {"real_label_zero_areas_spectrum", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --label 6 --largest --count 6 --out {dir}/l6", "", true, "20 surfels of zero area"},
    {"real_label_zero_areas_heat", "heat", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --label 6 --largest --tau 2 --steps 4 --out {dir}/l6h", "", true, "| 2 |"},
    // Issue 22: labels in batch. A failing structure is a column of NaN with its reason, never a
    // stopped batch: a label absent from the volume, label 0, a one-voxel label; a table of names
    // that does not parse falls back to label_N with a warning; a thousand components and a label
    // touching the border are structures like any other.
    {"batch_absent_label", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --labels 0,6,200 --count 5 --out {dir}/b1", "", true, "| 200 | label_200 | failed: no voxel has the label 200"},
    {"batch_background_label", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --labels 0,6 --count 5 --out {dir}/b2", "", true, "| 0 | label_0 | failed: label 0 is the background"},
    {"batch_names_table", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --labels 6 --count 5 --names {data}/JHU-WhiteMatter-labels-2mm.nii.txt --out {dir}/b3", "", true, "| 6 | Fornix_(column_and_body_of_fornix) | ok | 1 | 190 | 20 |"},
    {"batch_bad_names_table", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --labels 6 --count 5 --names {dir}/batch_bad_names_table.img --out {dir}/b4", "no table here\n\n# a comment\nsix Fornix\n", true, "| 6 | label_6 | ok |"},
    {"batch_missing_names_table", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --labels 6 --names {dir}/does_not_exist.txt --out {dir}/b5", "", false, "cannot read the table of names"},
    {"batch_bad_label_list", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --labels 3,x --out {dir}/b6", "", false, "'x' is not a label"},
    {"batch_one_voxel_label", "spectrum", "--volume {dir}/batch_one_voxel_label.npy --h 1 --labels 1,3 --count 5 --out {dir}/b7", npy_labels(), true, "| 1 | label_1 | failed: every surface has fewer than 8 surfels"},
    {"batch_thousand_components", "spectrum", "--volume {dir}/batch_thousand_components.npy --h 1 --labels 2 --min-size 0 --count 5 --out {dir}/b8", npy_labels(), true, "| 2 | label_2 | ok | 1000 | 6000 | 0 |"},
    {"batch_label_at_the_border", "spectrum", "--volume {dir}/batch_label_at_the_border.npy --h 1 --labels all --count 5 --out {dir}/b9", npy_labels(), true, "| 3 | label_3 | ok | 1 | 54 | 0 |"},
    {"batch_names_without_labels", "spectrum", "--volume {data}/JHU-WhiteMatter-labels-2mm.nii.gz --label 6 --names x.txt", "", false, "go with --labels"},
    {"batch_needs_a_volume", "spectrum", "--shape sphere --labels all", "", false, "--labels needs a segmentation"},
    {"negative_label", "spectrum", "--volume {data}/ball.nii.gz --label -5", "", false, "--label"},
    {"volume_kR_covers_object", "operator", "--volume {data}/ball.nii.gz --kR 100", "", false, "is wider than the whole set"},
    {"volume_memory_limit", "operator", "--volume {data}/ball.nii.gz --memory-limit 1000", "", false, "above the memory limit"},
    {"surface_memory_limit", "spectrum", "--shape sphere --memory-limit 1000", "", false, "above the memory limit"},
    {"surface_operator_npz", "operator", "--shape torus --h 0.1 --format npz --out {dir}/torus", "", true, "torus/surfels.ply"},
    {"surface_convergence", "convergence", "--shape torus --h 0.2 0.15 --out {dir}/cv3", "", true, "| exact | "},
    {"convergence_image", "convergence", "--image {data}/ten_squares.pbm", "", false, "measures errors against an exact shape"},
    {"convergence_volume", "convergence", "--volume {data}/ball.nii.gz", "", false, "images and volumes have none"},
    {"surface_convergence_function", "convergence", "--shape sphere --function cos1", "", false, "test functions are x2 and xy"},
    // The surface sweep without storing L (one product per h; the same errors, test_matrix_free).
    {"surface_convergence_matrix_free", "convergence", "--shape sphere --h 0.2 --matrix-free --out {dir}/cmf", "", true, "| 0.2 | ii | L | 462 | (matrix-free) |"},
    {"surface_convergence_bias_corrected", "convergence", "--shape sphere --h 0.2 --matrix-free --bias-correction --out {dir}/cbc", "", true, "| 0.2 | ii | bias-corrected | 462 | (matrix-free) |"},
    // --normals picks the rows: with exact alone the table opens on an exact row (ii would come
    // first); with ii alone the table ends on the ii bias-corrected row (exact would follow).
    {"surface_convergence_exact_normals_only", "convergence", "--shape sphere --h 0.2 --matrix-free --normals exact --out {dir}/cne", "", true, "|---|---|---|---|---|---|---|---|\n| 0.2 | exact | L | 462 | (matrix-free) |"},
    {"surface_convergence_ii_normals_only", "convergence", "--shape sphere --h 0.2 --matrix-free --bias-correction --normals ii --out {dir}/cni", "", true, "| 0.2 | ii | bias-corrected | 462 | (matrix-free) | 0.8 | 0.0254 | 15.622% |\n\n| normals |"},
    {"surface_convergence_bad_normals", "convergence", "--shape sphere --normals true", "", false, "--normals"},
    {"curve_convergence_normals", "convergence", "--shape flower --normals ii", "", false, "--normals is for surfaces here"},
    {"curve_convergence_bias_correction", "convergence", "--shape flower --bias-correction", "", false, "--bias-correction is for surfaces here"},
    {"curve_convergence_matrix_free", "convergence", "--shape flower --matrix-free", "", false, "--matrix-free is for surfaces here"},
    {"volume_labels_largest", "operator", "--volume {data}/../fuzz/volume_corpus/labels_u2.npy --largest --kR 0.5 --length-scale 1 --out {dir}/lab", "", true, "surfels.ply"},
    {"surface_heat", "heat", "--shape sphere --h 0.15 --tau 0.2 --steps 10 --snapshots 3 --out {dir}/heat3", "", true, "heat.ply"},
    {"matrix_free_euclidean", "spectrum", "--matrix-free --distance euclidean", "", false, "only the geodesic distance"},
    {"tau_negative", "heat", "--tau -1", "", false, "--tau must be > 0"},
    {"steps_zero", "heat", "--steps 0", "", false, "--steps must be >= 1"},
    {"unwritable_output", "operator", "--shape circle --h 0.1 --out /proc/digilap_cannot_write", "", false, "cannot create directory"},
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class BadInput : public ::testing::TestWithParam<Case> {};

TEST_P(BadInput, ClearMessageAndExitCode) {
  const Case& c = GetParam();
  const auto dir = std::filesystem::temp_directory_path() / "digilap_bad_input";
  std::filesystem::create_directories(dir);
  for (const char* extension : {".img", ".nii", ".npy"}) {
    const std::string file = std::string(c.name) + extension;
    if (c.args.find(file) != std::string::npos) std::ofstream(dir / file, std::ios::binary) << c.file;
  }
  const std::string command =
      app_path(c.app) + " --quiet " + replace_all(replace_all(c.args, "{dir}", dir.string()), "{data}", DIGILAP_SOURCE_DATA) + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[4096];
  while (std::size_t n = fread(buffer, 1, sizeof buffer, pipe)) output.append(buffer, n);
  const int status = pclose(pipe);
  ASSERT_TRUE(WIFEXITED(status)) << "crashed (signal): " << command << "\n" << output;
  const int code = WEXITSTATUS(status);
  if (c.succeeds) EXPECT_EQ(code, 0) << command << "\n" << output;
  else EXPECT_NE(code, 0) << command << "\n" << output;
  EXPECT_NE(output.find(c.fragment), std::string::npos) << "expected '" << c.fragment << "' in:\n" << output;
  // Never a sanitizer report, whatever the outcome.
  EXPECT_EQ(output.find("runtime error"), std::string::npos) << output;
  EXPECT_EQ(output.find("AddressSanitizer"), std::string::npos) << output;
}

INSTANTIATE_TEST_SUITE_P(Table, BadInput, ::testing::ValuesIn(kCases),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
