// surface/volume.hpp: volumes read from .npy and NIfTI files written here byte by byte, the
// same voxels and surfels as the digitization they hold; storage bounded by the voxels whatever
// the shape; every malformed or unsupported file refused with the file and the reason.
#include "digilap/surface/volume.hpp"
#include "error_of.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

#include <nifti1.h>
#include <nifti2.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>
#include <cstring>
#include <fstream>
#include <limits>
#include <tuple>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

// --- Volumes in (.npy) ---------------------------------------------------------------------------

namespace {
std::string npy(const std::string& descr, bool fortran, const std::vector<std::size_t>& shape, const std::string& data) {
  std::string dims;
  for (std::size_t d : shape) dims += std::to_string(d) + ",";
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': " + (fortran ? "True" : "False") + ", 'shape': (" + dims + "), }";
  dict.append((64 - (10 + dict.size() + 1) % 64) % 64, ' ');
  dict += '\n';
  return std::string("\x93NUMPY\x01\x00", 8) + static_cast<char>(dict.size() & 0xff) + static_cast<char>(dict.size() >> 8) + dict + data;
}
std::string write(const std::string& name, const std::string& bytes) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}
}  // namespace

// A digitized sphere written as a (plane, row, column) uint8 array, in C and in Fortran order,
// and as labels in a uint16 segmentation: read back, the same voxels (shifted to the array's
// corner) and the same surfels.
TEST(Surface, NpyVolumesReadBackTheVoxels) {
  const double h = 0.1;
  const VoxelSet sphere = digitize(Sphere(), h);
  const int n = 24, shift = 12;  // the sphere's voxels -11..11 land in 1..23
  std::string c_order(n * n * n, '\0'), f_order(n * n * n, '\0'), labels(2 * n * n * n, '\0');
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      for (int c = 0; c < n; ++c) {
        const bool in = sphere.contains(c - shift, b - shift, a - shift);  // element [a, b, c] is voxel (c, b, a)
        c_order[(a * n + b) * n + c] = in;
        f_order[a + n * (b + n * c)] = in;
        labels[2 * ((a * n + b) * n + c)] = in ? 3 : (c < 2 ? 7 : 0);  // the sphere has label 3, a slab label 7
      }
  const SurfelSet expected = extract_surfels(sphere);
  for (const auto& [name, bytes, options] :
       {std::tuple{"c.npy", npy("|u1", false, {24, 24, 24}, c_order), VolumeOptions{h}},
        std::tuple{"f.npy", npy("|b1", true, {24, 24, 24}, f_order), VolumeOptions{h}},
        std::tuple{"labels.npy", npy("<u2", false, {24, 24, 24}, labels), VolumeOptions{h, 3}}}) {
    const VoxelSet v = read_npy_volume(write(name, bytes), options);
    EXPECT_EQ(v.voxel_count(), sphere.voxel_count()) << name;
    EXPECT_TRUE(v.contains(shift, shift, shift)) << name;
    EXPECT_EQ(extract_surfels(v).size(), expected.size()) << name;
  }
  const VoxelSet slab = read_npy_volume(write("labels.npy", npy("<u2", false, {24, 24, 24}, labels)), VolumeOptions{0, 7});
  EXPECT_EQ(slab.voxel_count(), 2 * n * n - 0);  // c = 0, 1: every (a, b) outside the sphere
  EXPECT_DOUBLE_EQ(slab.h(), 1.0);  // voxel units by default: padding changes nothing
}

// A one-voxel-thick slab stored across the rows (n x n x 1 in C order: every row one voxel) and
// along them (1 x n x n): the same voxels and surfels, and storage bounded by the grid's voxels
// (8 bytes per row and per run), not by a list per row (24+ bytes each: 2 GB at 8000 x 8000, issue 25).
TEST(Surface, VoxelStorageIsBoundedByTheVoxelsWhateverTheShape) {
  const int n = 400;
  std::string across(n * n, '\0');
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) across[a * n + b] = (a - 200) * (a - 200) + (b - 200) * (b - 200) < 150 * 150;
  const VoxelSet thin = read_npy_volume(write("across.npy", npy("|u1", false, {n, n, 1}, across)));
  const VoxelSet wide = read_npy_volume(write("along.npy", npy("|u1", false, {1, n, n}, across)));
  const VoxelSet from_mask = VoxelSet::from_mask(1.0, reinterpret_cast<const std::uint8_t*>(across.data()), 1, n, n, 1, 1, n);
  EXPECT_EQ(thin.voxel_count(), wide.voxel_count());
  EXPECT_EQ(from_mask.voxel_count(), wide.voxel_count());
  EXPECT_EQ(extract_surfels(thin).size(), extract_surfels(wide).size());
  const double grid_voxels = static_cast<double>(n) * n;
  for (const VoxelSet* v : {&thin, &wide, &from_mask}) EXPECT_LE(static_cast<double>(v->memory_bytes()), 16 * grid_voxels + 64);
  EXPECT_LT(static_cast<double>(wide.memory_bytes()), 16.0 * n + 8.0 * 2 * n + 64);  // n rows, one or two runs each

  // Compressed rows are checked, not trusted.
  auto fragment = [](std::vector<std::int64_t> offsets, std::vector<digilap::Run> runs) {
    return error_of([&] { VoxelSet::from_compressed_rows(1.0, 0, 0, 2, 1, offsets, runs); });
  };
  EXPECT_NE(fragment({0, 1}, {{0, 1}}).find("nj x nk + 1"), std::string::npos);
  EXPECT_NE(fragment({0, 1, 2}, {{0, 1}}).find("nj x nk + 1"), std::string::npos);
  EXPECT_NE(fragment({0, 2, 1}, {{0, 1}}).find("must not decrease"), std::string::npos);
  EXPECT_NE(fragment({0, 1, 0}, {}).find("must not decrease"), std::string::npos);
  EXPECT_NE(fragment({0, 2, 2}, {{0, 3}, {2, 4}}).find("sorted and disjoint"), std::string::npos);
  EXPECT_NE(fragment({0, 1, 1}, {{2, 2}}).find("non-empty"), std::string::npos);
  EXPECT_EQ(VoxelSet::from_compressed_rows(1.0, 0, 0, 2, 1, {0, 2, 3}, {{0, 1}, {2, 4}, {5, 6}}).voxel_count(), 4);
}

// The peak of reading such a slab, not only what is kept: 3000 x 3000 x 1, 9e6 rows of one
// voxel, read in a child process whose peak resident memory the kernel reports. Storage is
// 16 bytes per voxel (144 MB) plus the file (9 MB); one list per row peaked at 540 MB (measured).
TEST(Surface, ReadingAThinSlabPeaksNearItsStorage) {
  const int n = 3000;
  const std::string path = write("slab.npy", npy("|u1", false, {n, n, 1}, std::string(static_cast<std::size_t>(n) * n, '\1')));
  rusage self{};
  getrusage(RUSAGE_SELF, &self);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(read_npy_volume(path).voxel_count() == std::int64_t(n) * n ? 0 : 1);  // serial reader: no OpenMP after fork
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  rusage children{};
  getrusage(RUSAGE_CHILDREN, &children);
  const double peak_mb = (static_cast<double>(children.ru_maxrss) - static_cast<double>(self.ru_maxrss)) / 1024;
  EXPECT_LT(peak_mb, 250) << "reading 9e6 one-voxel rows peaked " << peak_mb << " MB above the parent";
}

// Every malformed or unsupported file is refused with the file and the reason.
TEST(Surface, BadNpyVolumesAreRefused) {
  const std::string cube(8, '\1');
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "the file is empty"},
      {"GIF89a....", "not a .npy file"},
      {npy("|u1", false, {2, 2, 2}, "\1\1\1"), "truncated: the data holds 3 of 8 bytes"},
      {npy("|u1", false, {4, 2}, cube), "a volume needs 3 dimensions, got 2"},
      {npy("<c16", false, {1, 1, 1}, std::string(16, '\0')), "dtype '<c16' is not supported"},
      {npy("<f8", false, {1, 1, 1}, std::string("\0\0\0\0\0\0\xf8\x7f", 8)), "voxel (0, 0, 0) is NaN"},
      {std::string("\x93NUMPY\x01\x00\x40\x00", 10) + "{'descr': '|u1', 'fortran_order': False, 'shape': (-2, 2, 2), }   \n",
       "the dimension '-' is not a size"},
      {npy("|u1", false, {2, 0, 2}, ""), "the volume is empty"},
      {npy("|u1", false, {2, 2, 2}, std::string(8, '\0')), "no voxel reaches the threshold"},
      {npy("|u1", false, {100000, 100000, 100000}, ""), "above the limit"},
      {npy("|u1", false, {100000000000, 100000000000, 100000000000}, ""), "its 1e+33 voxels are above the limit"},
      {std::string("\x93NUMPY\x01\x00\xff\xff", 10), "truncated header"},
      {std::string("\x93NUMPY\x01\x00\x10\x00", 10) + "{'descr': '|u1'}", "no 'fortran_order'"},
  };
  for (const auto& [bytes, fragment] : cases) {
    const std::string path = write("bad.npy", bytes);
    const std::string message = error_of([&] { read_npy_volume(path); });
    EXPECT_NE(message.find(fragment), std::string::npos) << "message: " << message;
    EXPECT_NE(message.find("bad.npy"), std::string::npos) << message;
  }
  EXPECT_NE(error_of([] { read_npy_volume("/nonexistent/volume.npy"); }).find("cannot open"), std::string::npos);
}

// --- Volumes in (NIfTI) --------------------------------------------------------------------------

namespace {
// A NIfTI file written here field by field from the standard's header structs (not through
// nifticlib, which reads it back): version 1 or 2, gzipped when the name ends in .gz.
struct NiftiSample {
  int version = 1;
  std::int64_t dim[8] = {3, 1, 1, 1, 1, 1, 1, 1};
  int datatype = DT_UINT8, bitpix = 8;
  double spacing[3] = {1, 1, 1};
  double slope = 0, inter = 0;
  const char* magic = nullptr;  // a wrong magic on purpose
  std::string data;
};
std::string nifti_bytes(const NiftiSample& s) {
  std::string header;
  if (s.version == 1) {
    nifti_1_header h{};
    h.sizeof_hdr = 348;
    for (int d = 0; d < 8; ++d) h.dim[d] = static_cast<short>(s.dim[d]);
    h.datatype = static_cast<short>(s.datatype), h.bitpix = static_cast<short>(s.bitpix);
    h.pixdim[0] = 1;
    for (int d = 0; d < 3; ++d) h.pixdim[d + 1] = static_cast<float>(s.spacing[d]);
    h.vox_offset = 352, h.scl_slope = static_cast<float>(s.slope), h.scl_inter = static_cast<float>(s.inter);
    h.xyzt_units = NIFTI_UNITS_MM;
    std::memcpy(h.magic, s.magic ? s.magic : "n+1", 4);
    header.assign(reinterpret_cast<const char*>(&h), sizeof h);
    header.append(4, '\0');  // no extensions
  } else {
    nifti_2_header h{};
    h.sizeof_hdr = 540;
    std::memcpy(h.magic, "n+2\0\r\n\032\n", 8);
    for (int d = 0; d < 8; ++d) h.dim[d] = s.dim[d];
    h.datatype = static_cast<short>(s.datatype), h.bitpix = static_cast<short>(s.bitpix);
    h.pixdim[0] = 1;
    for (int d = 0; d < 3; ++d) h.pixdim[d + 1] = s.spacing[d];
    h.vox_offset = 544, h.scl_slope = s.slope, h.scl_inter = s.inter;
    h.xyzt_units = NIFTI_UNITS_MM;
    header.assign(reinterpret_cast<const char*>(&h), sizeof h);
    header.append(4, '\0');
  }
  return header + s.data;
}
std::string write_nifti(const std::string& name, const std::string& bytes) {
  const std::string path = ::testing::TempDir() + "/" + name;
  if (name.size() > 3 && name.compare(name.size() - 3, 3, ".gz") == 0) {
    gzFile f = gzopen(path.c_str(), "wb");
    gzwrite(f, bytes.data(), static_cast<unsigned>(bytes.size()));
    gzclose(f);
  } else {
    std::ofstream(path, std::ios::binary) << bytes;
  }
  return path;
}
template <class T>
std::string raw(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}
}  // namespace

// A digitized sphere written as NIfTI-1 uint8 (.nii), NIfTI-1 int16 labels (.nii.gz), NIfTI-2
// float32 (.nii) and scaled uint8 (stored 1, slope 2, inter 1: value 3): read back, the same
// voxels at the file's index and the same surfels; h is the file's spacing unless given.
TEST(Surface, NiftiVolumesReadBackTheVoxels) {
  const VoxelSet sphere = digitize(Sphere(), 0.1);
  const int n = 24, shift = 12;
  std::vector<std::uint8_t> mask(n * n * n);
  std::vector<std::int16_t> labels(n * n * n);
  std::vector<float> levels(n * n * n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const bool in = sphere.contains(i - shift, j - shift, k - shift);
        const std::size_t at = static_cast<std::size_t>((k * n + j) * n + i);  // x fastest
        mask[at] = in;
        labels[at] = in ? 3 : (i < 2 ? -7 : 0);
        levels[at] = in ? 0.75f : 0.25f;
      }
  auto sample = [&](int version, int datatype, int bitpix, std::string data, double spacing) {
    NiftiSample s;
    s.version = version, s.datatype = datatype, s.bitpix = bitpix, s.data = std::move(data);
    s.dim[1] = s.dim[2] = s.dim[3] = n;
    s.spacing[0] = s.spacing[1] = s.spacing[2] = spacing;
    return s;
  };
  NiftiSample scaled = sample(1, DT_UINT8, 8, raw(mask), 0.1);
  scaled.slope = 2, scaled.inter = 1;
  VolumeOptions label3;
  label3.label = 3;
  VolumeOptions half;
  half.threshold = 0.5;
  const SurfelSet expected = extract_surfels(sphere);
  for (const auto& [name, s, options] :
       {std::tuple{"mask.nii", sample(1, DT_UINT8, 8, raw(mask), 0.1), VolumeOptions{}},
        std::tuple{"labels.nii.gz", sample(1, DT_INT16, 16, raw(labels), 0.1), label3},
        std::tuple{"levels.nii", sample(2, DT_FLOAT32, 32, raw(levels), 0.1), half},
        std::tuple{"scaled.nii", scaled, label3}}) {
    const VoxelSet v = read_volume(write_nifti(name, nifti_bytes(s)), options);
    EXPECT_EQ(v.voxel_count(), sphere.voxel_count()) << name;
    EXPECT_TRUE(v.contains(shift, shift, shift)) << name;
    EXPECT_FALSE(v.contains(0, 0, 0)) << name;
    EXPECT_EQ(extract_surfels(v).size(), expected.size()) << name;
    EXPECT_NEAR(v.h(), 0.1, 1e-7) << name;  // NIfTI-1 stores the spacing as float
  }
  VolumeOptions slab;
  slab.label = 0, slab.h = 0.5;  // background label 0: everything but the sphere and the slab
  const VoxelSet rest = read_volume(write_nifti("labels.nii.gz", nifti_bytes(sample(1, DT_INT16, 16, raw(labels), 0.1))), slab);
  EXPECT_EQ(rest.voxel_count(), n * n * n - sphere.voxel_count() - 2 * n * n);
  EXPECT_EQ(rest.h(), 0.5);
  // No spacing in the file (0): nifticlib reads it as 1, so h is one voxel unit.
  EXPECT_DOUBLE_EQ(read_volume(write_nifti("nospacing.nii", nifti_bytes(sample(1, DT_UINT8, 8, raw(mask), 0)))).h(), 1.0);
}

// Every malformed, unsupported or anisotropic file is refused with the file and the reason.
TEST(Surface, BadNiftiVolumesAreRefused) {
  auto cube = [](int n, std::string data = "") {
    NiftiSample s;
    s.dim[1] = s.dim[2] = s.dim[3] = n;
    s.data = data.empty() ? std::string(static_cast<std::size_t>(n) * n * n, '\1') : data;
    return s;
  };
  NiftiSample anisotropic = cube(4);
  anisotropic.spacing[2] = 2.5;
  NiftiSample series = cube(2, std::string(24, '\1'));
  series.dim[0] = 4, series.dim[4] = 3;
  NiftiSample complex_type = cube(2, std::string(64, '\1'));
  complex_type.datatype = DT_COMPLEX64, complex_type.bitpix = 64;
  NiftiSample pair = cube(2);
  pair.magic = "ni1";
  NiftiSample huge = cube(2);
  huge.version = 2, huge.dim[1] = huge.dim[2] = huge.dim[3] = 5000;
  NiftiSample dark = cube(2, std::string(8, '\0'));
  NiftiSample zero_dim = cube(2);
  zero_dim.dim[2] = 0;
  NiftiSample no_dims = cube(2);
  no_dims.version = 2, no_dims.dim[0] = 0;
  // NIfTI-2 spacings are doubles: 1e200 would make every area inf, 1e-200 every area 0 (fuzzer).
  NiftiSample vast = cube(2), tiny = cube(2);
  vast.version = tiny.version = 2;
  for (int d = 0; d < 3; ++d) vast.spacing[d] = 1e200, tiny.spacing[d] = 1e-200;
  // A 2-D image is refused as the .npy reader refuses it (it was read as a one-voxel slab).
  NiftiSample flat = cube(4, std::string(16, '\1'));
  flat.dim[0] = 2, flat.dim[3] = 1;
  // NaN compares false with every threshold: it was read as background, a hole in the object.
  std::vector<float> levels(8, 1.0f);
  levels[5] = std::numeric_limits<float>::quiet_NaN();
  NiftiSample with_nan = cube(2, raw(levels));
  with_nan.datatype = DT_FLOAT32, with_nan.bitpix = 32;
  const std::string good = nifti_bytes(cube(4));
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"bad.nii", nifti_bytes(vast), "the voxel spacing 1e+200 is outside [1e-30, 1e+30]"},
      {"bad.nii", nifti_bytes(tiny), "the voxel spacing 1e-200 is outside [1e-30, 1e+30]"},
      {"bad.nii", "", "the file is empty"},
      {"bad.nii", "GIF89a....", "truncated header (10 bytes"},
      {"bad.nii", std::string(400, 'x'), "not a NIfTI file (sizeof_hdr is"},
      {"bad.nii", good.substr(0, 200), "truncated header (200 bytes"},
      {"bad.nii", good.substr(0, 352 + 30), "truncated: the data needs 64 bytes from byte 352"},
      {"bad.nii.gz", good.substr(0, 352 + 30), "truncated or unreadable voxel data"},
      {"bad.nii", nifti_bytes(anisotropic), "anisotropic voxel spacing 1 x 1 x 2.5 mm"},
      {"bad.nii", nifti_bytes(series), "holds 3 volumes"},
      {"bad.nii", nifti_bytes(complex_type), "data type COMPLEX64 (code 32) is not supported"},
      {"bad.nii", nifti_bytes(pair), ".hdr/.img pair"},
      {"bad.nii", nifti_bytes(huge), "125000000000 voxels are above the limit"},
      {"bad.nii", nifti_bytes(dark), "no voxel reaches the threshold"},
      {"bad.nii.gz", std::string(400, 'x'), "not a NIfTI file"},
      {"bad.nii", nifti_bytes(zero_dim), "dimension 2 is 0"},
      {"bad.nii.gz", nifti_bytes(no_dims), "dim[0] is 0"},
      {"bad.nii", nifti_bytes(flat), "it is a 2-D image; a volume needs 3 dimensions"},
      {"bad.nii", nifti_bytes(with_nan), "voxel (1, 0, 1) is NaN"},
  };
  for (const auto& [name, bytes, fragment] : cases) {
    const std::string path = write_nifti(name, bytes);
    const std::string message = error_of([&] { read_volume(path); });
    EXPECT_NE(message.find(fragment), std::string::npos) << name << " message: " << message;
    EXPECT_NE(message.find(name), std::string::npos) << message;
  }
  VolumeOptions label1;
  label1.label = 1;
  EXPECT_NE(error_of([&] { read_volume(write_nifti("nan.nii", nifti_bytes(with_nan)), label1); }).find("voxel (1, 0, 1) is NaN"),
            std::string::npos);
  EXPECT_NE(error_of([&] { read_labels(write_nifti("nan.nii", nifti_bytes(with_nan))); }).find("voxel (1, 0, 1) is NaN"),
            std::string::npos);
  // Inf is a value: above the threshold, a voxel of the object (NaN is the one refused).
  levels[5] = std::numeric_limits<float>::infinity();
  NiftiSample with_inf = cube(2, raw(levels));
  with_inf.datatype = DT_FLOAT32, with_inf.bitpix = 32;
  EXPECT_EQ(read_volume(write_nifti("inf.nii", nifti_bytes(with_inf))).voxel_count(), 8);
  // The fuzzer's input that smashed nifticlib's stack (NIfTI-2, dim[0] = 849): refused before it.
  EXPECT_NE(error_of([] { read_volume(DIGILAP_SOURCE_DATA "/../fuzz/volume_corpus/regression_nifti2_dim0_849.nii"); })
                .find("dim[0] is 849 (the number of dimensions must be 1 to 7)"),
            std::string::npos);
  // And the one whose 4th to 7th dimensions multiply past 2^63 (a count no integer holds).
  EXPECT_NE(error_of([] { read_volume(DIGILAP_SOURCE_DATA "/../fuzz/volume_corpus/regression_nifti2_extra_dims_overflow.nii"); })
                .find("e+"),
            std::string::npos);
  EXPECT_NE(error_of([] { read_volume(::testing::TempDir() + "/bad.vol"); }).find("unknown extension"), std::string::npos);
  EXPECT_NE(error_of([] { read_volume("/nonexistent/volume.nii.gz"); }).find("cannot open"), std::string::npos);
  EXPECT_NE(error_of([] { read_nifti_volume(::testing::TempDir() + "/plain.npy"); }).find(".nii or .nii.gz"), std::string::npos);
}

// --- Slabs: planes read alone (read_volume_slab, read_volume_info) -------------------------------

namespace {
// Every voxel of `whole` with k in [k_begin, k_end), and nothing else, is in `slab`.
void expect_planes_of(const VoxelSet& whole, const VoxelSet& slab, std::int64_t k_begin, std::int64_t k_end, int n,
                      const std::string& name) {
  std::int64_t expected = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const bool in_range = k >= k_begin && k < k_end;
        expected += in_range && whole.contains(i, j, k);
        ASSERT_EQ(slab.contains(i, j, k), in_range && whole.contains(i, j, k)) << name << " (" << i << ", " << j << ", " << k << ")";
      }
  EXPECT_EQ(slab.voxel_count(), expected) << name;
}
}  // namespace

// A 20 x 22 x 24 (x, y, z) volume of an off-centre ellipsoid and a label slab, in the four layouts
// a slab is read from (.npy C order, .npy Fortran order big-endian int16, .nii, .nii.gz float32):
// every plane range, including empty, clipped and whole ones, gives exactly the whole volume's
// voxels of those planes, and the header alone gives the sizes and h.
TEST(Surface, VolumeSlabsReadOnlyTheirPlanes) {
  const int nx = 20, ny = 22, nz = 24;
  std::string c_order(nx * ny * nz, '\0'), f_order(2 * nx * ny * nz, '\0');
  std::vector<float> levels(static_cast<std::size_t>(nx * ny * nz));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const double x = (i - 9.3) / 8, y = (j - 11.6) / 9, z = (k - 10.2) / 10;
        const std::int16_t label = x * x + y * y + z * z < 1 ? 5 : (k > 20 && i < 4 ? 9 : 0);
        c_order[static_cast<std::size_t>((k * ny + j) * nx + i)] = static_cast<char>(label);
        const std::size_t f = static_cast<std::size_t>(k + nz * (j + ny * i));  // element [k, j, i], Fortran order
        f_order[2 * f] = static_cast<char>(label >> 8), f_order[2 * f + 1] = static_cast<char>(label & 0xff);  // big-endian
        levels[static_cast<std::size_t>((k * ny + j) * nx + i)] = label == 5 ? 0.8f : 0.1f;
      }
  NiftiSample nii;
  nii.dim[1] = nx, nii.dim[2] = ny, nii.dim[3] = nz, nii.spacing[0] = nii.spacing[1] = nii.spacing[2] = 0.5;
  nii.data = c_order;
  NiftiSample gz = nii;
  gz.version = 2, gz.datatype = DT_FLOAT32, gz.bitpix = 32, gz.data = raw(levels);
  VolumeOptions label5;
  label5.label = 5;
  VolumeOptions half;
  half.threshold = 0.5;
  const std::vector<std::size_t> shape{static_cast<std::size_t>(nz), static_cast<std::size_t>(ny), static_cast<std::size_t>(nx)};
  for (const auto& [path, options, h] :
       {std::tuple{write("slab_c.npy", npy("|u1", false, shape, c_order)), VolumeOptions{}, 1.0},
        std::tuple{write("slab_f.npy", npy(">i2", true, shape, f_order)), label5, 1.0},
        std::tuple{write_nifti("slab.nii", nifti_bytes(nii)), VolumeOptions{}, 0.5},
        std::tuple{write_nifti("slab.nii.gz", nifti_bytes(gz)), half, 0.5}}) {
    const VolumeInfo info = read_volume_info(path, options);
    EXPECT_EQ(info.nx, nx) << path;
    EXPECT_EQ(info.ny, ny) << path;
    EXPECT_EQ(info.nz, nz) << path;
    EXPECT_DOUBLE_EQ(info.h, h) << path;
    const VoxelSet whole = read_volume(path, options);
    ASSERT_GT(whole.voxel_count(), 1000) << path;
    for (const auto& [k_begin, k_end] : {std::pair{0, 24}, std::pair{-5, 3}, std::pair{7, 8}, std::pair{10, 17}, std::pair{20, 40},
                                         std::pair{12, 12}, std::pair{30, 35}}) {
      const VoxelSet slab = read_volume_slab(path, k_begin, k_end, options);
      expect_planes_of(whole, slab, k_begin, k_end, std::max({nx, ny, nz}), path + " planes " + std::to_string(k_begin));
      EXPECT_DOUBLE_EQ(slab.h(), whole.h());
    }
  }
  EXPECT_NE(error_of([] { read_volume_slab("/nonexistent.npy", 0, 1); }).find("cannot open"), std::string::npos);
  EXPECT_NE(error_of([] { read_volume_info("volume.raw"); }).find("unknown extension"), std::string::npos);
}
