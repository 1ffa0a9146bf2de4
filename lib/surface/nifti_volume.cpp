// NIfTI-1 and NIfTI-2 single files (.nii, .nii.gz) through Debian's nifticlib (libnifti2, which
// reads both versions and gunzips through its znz layer). Before nifticlib sees a file, its
// first bytes are checked here against the standard's fixed fields (sizeof_hdr and magic), so
// that a file that is not NIfTI gets our message instead of nifticlib's stderr chatter; the
// sizes it declares are checked against the limit before any voxel is read.
#include "digilap/surface/volume.hpp"

#include "digilap/core/error.hpp"
#include "volume_grid.hpp"

#include <nifti2_io.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sstream>

namespace digilap::surface {

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
  throw Error("cannot read volume '" + path + "': " + why);
}

std::int32_t int32_at(const unsigned char* b, bool swap) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(b[swap ? 3 - i : i]) << (8 * i);
  return static_cast<std::int32_t>(v);
}

bool supported_type(int datatype) {
  switch (datatype) {
    case DT_UINT8: case DT_INT8: case DT_UINT16: case DT_INT16: case DT_UINT32: case DT_INT32:
    case DT_UINT64: case DT_INT64: case DT_FLOAT32: case DT_FLOAT64: return true;
    default: return false;
  }
}

std::int64_t int64_at(const unsigned char* b, bool swap) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(b[swap ? 7 - i : i]) << (8 * i);
  return static_cast<std::int64_t>(v);
}

// The fields nifticlib trusts, checked here first: sizeof_hdr (348 or 540, in either byte
// order), the single-file magic ("n+1" at byte 344, "n+2\0\r\n\032\n" at byte 4), and the
// dimensions. nifticlib 3.0.1 copies dim[1..dim[0]] into fixed arrays without checking dim[0]
// (a NIfTI-2 header with dim[0] = 849 smashed its stack under the fuzzer), so dim[0] must be in
// 1..7 and each used dimension >= 1 before it reads the file. gzread reads a plain file as it
// is, so the same code checks .nii and .nii.gz.
void check_header_bytes(const std::string& path) {
  gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) refuse(path, "cannot open the file (does it exist and is it readable?)");
  std::array<unsigned char, 540> head{};
  const int got = gzread(file, head.data(), static_cast<unsigned>(head.size()));
  gzclose(file);
  if (got <= 0) refuse(path, got == 0 ? "the file is empty" : "not a readable gzip stream");
  if (got < 348) refuse(path, "truncated header (" + std::to_string(got) + " bytes; NIfTI-1 needs 348)");
  const unsigned char* b = head.data();
  std::int64_t dim[8] = {};
  int datatype = 0;
  if (int32_at(b, false) == 348 || int32_at(b, true) == 348) {
    const bool swap = int32_at(b, true) == 348;
    if (std::memcmp(b + 344, "ni1", 4) == 0) refuse(path, "a NIfTI-1 header of a .hdr/.img pair; give the single-file .nii form");
    if (std::memcmp(b + 344, "n+1", 4) != 0) refuse(path, "not a NIfTI-1 file (no 'n+1' magic at byte 344)");
    auto int16_at = [&](int at) { return static_cast<std::int16_t>(swap ? b[at] << 8 | b[at + 1] : b[at + 1] << 8 | b[at]); };
    for (int d = 0; d < 8; ++d) dim[d] = int16_at(40 + 2 * d);
    datatype = int16_at(70);
  } else if (int32_at(b, false) == 540 || int32_at(b, true) == 540) {
    const bool swap = int32_at(b, true) == 540;
    if (got < 540) refuse(path, "truncated header (" + std::to_string(got) + " bytes; NIfTI-2 needs 540)");
    if (std::memcmp(b + 4, "n+2\0\r\n\032\n", 8) != 0) refuse(path, "not a single-file NIfTI-2 file (magic at byte 4)");
    for (int d = 0; d < 8; ++d) dim[d] = int64_at(b + 16 + 8 * d, swap);
    datatype = static_cast<std::int16_t>(swap ? b[12] << 8 | b[13] : b[13] << 8 | b[12]);
  } else {
    refuse(path, "not a NIfTI file (sizeof_hdr is " + std::to_string(int32_at(b, false)) + ", expected 348 or 540)");
  }
  if (!supported_type(datatype))
    refuse(path, std::string("data type ") + nifti_datatype_string(datatype) + " (code " + std::to_string(datatype) +
                     ") is not supported (integer or floating-point scalars)");
  if (dim[0] < 1 || dim[0] > 7) refuse(path, "dim[0] is " + std::to_string(dim[0]) + " (the number of dimensions must be 1 to 7)");
  for (int d = 1; d <= dim[0]; ++d)
    if (dim[d] < 1) refuse(path, "dimension " + std::to_string(d) + " is " + std::to_string(dim[d]));
}

// Element `at` of the loaded data as a double (the type was checked by supported_type).
double stored_value(const nifti_image& nim, std::size_t at) {
  const void* d = nim.data;
  switch (nim.datatype) {
    case DT_UINT8: return static_cast<const std::uint8_t*>(d)[at];
    case DT_INT8: return static_cast<const std::int8_t*>(d)[at];
    case DT_UINT16: return static_cast<const std::uint16_t*>(d)[at];
    case DT_INT16: return static_cast<const std::int16_t*>(d)[at];
    case DT_UINT32: return static_cast<const std::uint32_t*>(d)[at];
    case DT_INT32: return static_cast<const std::int32_t*>(d)[at];
    case DT_UINT64: return static_cast<double>(static_cast<const std::uint64_t*>(d)[at]);
    case DT_INT64: return static_cast<double>(static_cast<const std::int64_t*>(d)[at]);
    case DT_FLOAT32: return static_cast<const float*>(d)[at];
    default: return static_cast<const double*>(d)[at];  // DT_FLOAT64
  }
}

std::string spacing_text(double dx, double dy, double dz, int units) {
  std::ostringstream s;
  s << dx << " x " << dy << " x " << dz;
  const char* unit = units == NIFTI_UNITS_MM ? " mm" : units == NIFTI_UNITS_MICRON ? " micron" : units == NIFTI_UNITS_METER ? " m" : "";
  return s.str() + unit;
}

// nifticlib's loader replaces every NaN and Inf of float data by 0 without a word
// (nifti_read_buffer): a NaN would become background and an Inf above the threshold would be
// dropped. Float data is therefore read here, through zlib (plain and gzipped files alike) and
// byte-swapped as nifticlib does; the buffer is malloc'ed because nifti_image_free frees it.
// `skip` bytes of the data are skipped first (a slab of planes: read_volume_slab).
bool read_data(const std::string& path, nifti_image& nim, std::size_t skip, std::size_t bytes) {
  gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) return false;
  void* data = std::malloc(std::max<std::size_t>(bytes, 1));
  const auto start = static_cast<z_off_t>(nim.iname_offset + static_cast<std::int64_t>(skip));
  bool ok = data != nullptr && gzseek(file, start, SEEK_SET) == start;
  for (std::size_t at = 0; ok && at < bytes;) {
    const auto chunk = static_cast<unsigned>(std::min<std::size_t>(bytes - at, std::size_t{1} << 30));
    const int got = gzread(file, static_cast<char*>(data) + at, chunk);
    ok = got == static_cast<int>(chunk);
    at += chunk;
  }
  gzclose(file);
  if (!ok) {
    std::free(data);
    return false;
  }
  if (nim.byteorder != nifti_short_order()) {
    const auto count = static_cast<std::int64_t>(bytes / static_cast<std::size_t>(nim.nbyper));
    if (nim.nbyper == 2) nifti_swap_2bytes(count, data);
    else if (nim.nbyper == 4) nifti_swap_4bytes(count, data);
    else if (nim.nbyper == 8) nifti_swap_8bytes(count, data);
  }
  nim.data = data;
  return true;
}

struct NiftiFree {
  void operator()(nifti_image* nim) const { nifti_image_free(nim); }
};

}  // namespace

namespace {
// A loaded NIfTI volume as a grid of (scaled) values, with its checks done.
struct NiftiGrid {
  std::unique_ptr<nifti_image, NiftiFree> nim;
  std::int64_t nx = 0, ny = 0, nz = 0;
  double h = 1, slope = 1, inter = 0;
  bool scaled = false;
  std::string path;
  std::int64_t plane0 = 0;  // the first plane held in nim->data (a slab: read_volume_slab)
  double operator()(std::int64_t i, std::int64_t j, std::int64_t k) const {
    const double raw = stored_value(*nim, static_cast<std::size_t>(((k - plane0) * ny + j) * nx + i));
    // NaN is no label and compares false with every threshold: silently background, a hole in
    // the object. Refused as the .npy reader refuses it (Inf is a value: above any threshold).
    if (std::isnan(raw)) detail::refuse_nan_voxel(path, i, j, k);
    return scaled ? slope * raw + inter : raw;
  }
};

// The header read and checked; the data loaded unless load is false.
NiftiGrid open_nifti(const std::string& path, const VolumeOptions& o, bool load = true) {
  if (!(ends_with(path, ".nii") || ends_with(path, ".nii.gz")))
    refuse(path, "a NIfTI volume is read from a .nii or .nii.gz file");
  if (!(o.h == 0 || (o.h > 0 && std::isfinite(o.h)))) require_positive("read_nifti_volume: h", o.h);
  if (!std::isfinite(o.threshold)) refuse(path, "the threshold must be finite");
  check_header_bytes(path);
  // nifticlib's debug level 1 prints notes (qform repairs and the like) that are not errors.
  nifti_set_debug_level(0);
  std::unique_ptr<nifti_image, NiftiFree> nim(nifti_image_read(path.c_str(), 0));
  if (!nim) refuse(path, "nifticlib could not read its header (invalid dimensions or fields)");
  // Sizes from the header, in double (NIfTI-2 dimensions are 64-bit), before reading data.
  double voxels = 1, extra = 1;
  for (int d = 1; d <= 7; ++d) {
    if (d <= nim->ndim && nim->dim[d] < 1) refuse(path, "dimension " + std::to_string(d) + " is " + std::to_string(nim->dim[d]));
    const double n = d <= nim->ndim ? static_cast<double>(nim->dim[d]) : 1.0;
    (d <= 3 ? voxels : extra) *= n;
  }
  // A 2-D file is an image, not a one-voxel slab (the .npy reader refuses 2-D arrays the same way).
  if (nim->ndim < 3)
    refuse(path, "it is a " + std::to_string(nim->ndim) +
                     "-D image; a volume needs 3 dimensions (a 2-D mask goes through the curve pipeline: --image with a "
                     "PNG or PGM, digilap.laplacian in Python; one slice as a volume: save it with shape (nx, ny, 1))");
  if (extra != 1)
    refuse(path, "it holds " + detail::count_text(extra) +
                     " volumes (a time series or vector data); give one 3-D volume");
  if (voxels > static_cast<double>(o.max_voxels))
    refuse(path, "its " + detail::count_text(voxels) + " voxels are above the limit of " +
                     std::to_string(o.max_voxels));
  const std::int64_t nx = nim->nx, ny = std::max<std::int64_t>(nim->ny, 1), nz = std::max<std::int64_t>(nim->nz, 1);
  if (std::max({nx, ny, nz}) > kMaxPixelIndex) refuse(path, "a dimension is above " + std::to_string(kMaxPixelIndex));
  // The operator is built on cubes: unequal spacings are refused (resample first), with the
  // spacing named. nifticlib reads a spacing <= 0 as 1 (one voxel unit).
  const double dx = std::fabs(nim->dx), dy = std::fabs(nim->dy), dz = std::fabs(nim->dz);
  const bool has_spacing = dx > 0 && dy > 0 && dz > 0 && std::isfinite(dx + dy + dz);
  // Spacings computed by resampling tools and stored as float (1 x 1 x 1.00002) are equal within
  // 1e-4; a given h declares the voxels cubes up to 1% (the user's override, documented in
  // VolumeOptions::h); beyond that the operator would be wrong, whatever h says.
  const double anisotropy_tolerance = o.h > 0 ? 1e-2 : 1e-4;
  if (has_spacing && (std::max({dx, dy, dz}) - std::min({dx, dy, dz})) > anisotropy_tolerance * std::max({dx, dy, dz}))
    refuse(path, "anisotropic voxel spacing " + spacing_text(dx, dy, dz, nim->xyz_units) +
                     ": the operator assumes cubic voxels; resample the volume to equal spacing first");
  // A NIfTI-2 spacing is a double: 1e200 mm would make every area inf (found by the fuzzer).
  if (o.h == 0 && has_spacing && !(dx >= kMinGridStep && dx <= kMaxGridStep)) {
    std::ostringstream why;
    why << "the voxel spacing " << dx << " is outside [" << kMinGridStep << ", " << kMaxGridStep
        << "], where areas and eigenvalues overflow or vanish; give --h (VolumeOptions::h) in another unit";
    refuse(path, why.str());
  }
  std::error_code error;
  const std::uintmax_t file_size = std::filesystem::file_size(path, error);
  if (error) refuse(path, "cannot read its size (" + error.message() + ")");
  if (!ends_with(path, ".gz") &&
      static_cast<double>(nim->iname_offset) + voxels * nim->nbyper > static_cast<double>(file_size))
    refuse(path, "truncated: the data needs " + detail::count_text(voxels * nim->nbyper) +
                     " bytes from byte " + std::to_string(nim->iname_offset) + ", the file has " +
                     std::to_string(file_size));
  const bool floating = nim->datatype == DT_FLOAT32 || nim->datatype == DT_FLOAT64;
  if (load) {
    const bool loaded = floating ? read_data(path, *nim, 0, static_cast<std::size_t>(voxels) * static_cast<std::size_t>(nim->nbyper))
                                 : nifti_image_load(nim.get()) == 0 && nim->data != nullptr;
    if (!loaded) refuse(path, "truncated or unreadable voxel data");
  }
  // Scaled values, as NIfTI readers report them, when the file gives a slope.
  const double slope = nim->scl_slope, inter = nim->scl_inter;
  const bool scaled = slope != 0 && std::isfinite(slope) && std::isfinite(inter) && !(slope == 1 && inter == 0);
  NiftiGrid grid;
  grid.h = o.h > 0 ? o.h : has_spacing ? dx : 1.0;  // no spacing: voxel units
  grid.nx = nx, grid.ny = ny, grid.nz = nz, grid.slope = slope, grid.inter = inter, grid.scaled = scaled;
  grid.nim = std::move(nim);
  grid.path = path;
  return grid;
}
}  // namespace

namespace detail {
VolumeInfo nifti_volume_info(const std::string& path, const VolumeOptions& o) {
  const NiftiGrid grid = open_nifti(path, o, false);
  return {grid.nx, grid.ny, grid.nz, grid.h};
}

// Planes [k_begin, k_end) only: one block of bytes (the planes are contiguous in NIfTI), read
// through zlib (a .nii.gz is inflated up to the slab's end: prefer .nii for many ranks).
VoxelSet read_nifti_slab(const std::string& path, std::int64_t k_begin, std::int64_t k_end, const VolumeOptions& o) {
  NiftiGrid grid = open_nifti(path, o, false);
  k_begin = std::clamp<std::int64_t>(k_begin, 0, grid.nz), k_end = std::clamp<std::int64_t>(k_end, k_begin, grid.nz);
  const auto plane_bytes = static_cast<std::size_t>(grid.nx * grid.ny) * static_cast<std::size_t>(grid.nim->nbyper);
  if (!read_data(path, *grid.nim, static_cast<std::size_t>(k_begin) * plane_bytes, static_cast<std::size_t>(k_end - k_begin) * plane_bytes))
    refuse(path, "truncated or unreadable voxel data");
  grid.plane0 = k_begin;
  return voxel_set_from_grid(grid.h, grid.nx, grid.ny, k_end - k_begin, [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return is_foreground(o, grid(i, j, k));
  }, k_begin);
}
}  // namespace detail

VoxelSet read_nifti_volume(const std::string& path, const VolumeOptions& o) {
  const NiftiGrid grid = open_nifti(path, o);
  VoxelSet set = detail::voxel_set_from_grid(grid.h, grid.nx, grid.ny, grid.nz, [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return detail::is_foreground(o, grid(i, j, k));
  });
  if (set.empty()) refuse(path, detail::no_foreground_reason(o));
  return set;
}

std::vector<LabelVoxels> read_nifti_labels(const std::string& path, const VolumeOptions& o) {
  const NiftiGrid grid = open_nifti(path, o);
  return detail::label_sets_from_grid(path, grid.h, grid.nx, grid.ny, grid.nz, grid);
}

std::vector<LabelVoxels> read_labels(const std::string& path, const VolumeOptions& options) {
  if (ends_with(path, ".npy")) return read_npy_labels(path, options);
  if (ends_with(path, ".nii") || ends_with(path, ".nii.gz")) return read_nifti_labels(path, options);
  throw Error("cannot read volume '" + path + "': unknown extension (.npy, .nii or .nii.gz)");
}

VolumeInfo read_volume_info(const std::string& path, const VolumeOptions& options) {
  if (ends_with(path, ".npy")) return detail::npy_volume_info(path, options);
  if (ends_with(path, ".nii") || ends_with(path, ".nii.gz")) return detail::nifti_volume_info(path, options);
  throw Error("cannot read volume '" + path + "': unknown extension (.npy, .nii or .nii.gz)");
}

VoxelSet read_volume_slab(const std::string& path, std::int64_t k_begin, std::int64_t k_end, const VolumeOptions& options) {
  if (ends_with(path, ".npy")) return detail::read_npy_slab(path, k_begin, k_end, options);
  if (ends_with(path, ".nii") || ends_with(path, ".nii.gz")) return detail::read_nifti_slab(path, k_begin, k_end, options);
  throw Error("cannot read volume '" + path + "': unknown extension (.npy, .nii or .nii.gz)");
}

VoxelSet read_volume(const std::string& path, const VolumeOptions& options) {
  if (ends_with(path, ".npy")) return read_npy_volume(path, options);
  if (ends_with(path, ".nii") || ends_with(path, ".nii.gz")) return read_nifti_volume(path, options);
  throw Error("cannot read volume '" + path + "': unknown extension (.npy, .nii or .nii.gz)");
}

}  // namespace digilap::surface
