#include "digilap/surface/volume.hpp"

#include "digilap/core/error.hpp"
#include "volume_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <cctype>
#include <cstdint>
#include <vector>

namespace digilap::surface {

namespace {

// The .npy header: magic "\x93NUMPY", version, a little-endian length, then a Python dict
// {'descr': ..., 'fortran_order': ..., 'shape': (...)}. Parsed here (no Debian package reads
// .npy from C++); only what this reader supports is accepted, everything else refused.
struct NpyHeader {
  std::string descr;
  bool fortran = false;
  std::vector<std::int64_t> shape;
  std::size_t data_offset = 0;
};

// The element type of a .npy array: every numeric dtype NumPy writes for a volume (bool,
// unsigned and signed integers of 1-8 bytes, float32, float64), either byte order.
struct NpyDtype {
  char kind = 0;  // 'b', 'u', 'i', 'f'; 0 when not supported
  std::size_t size = 0;
  bool big_endian = false;
};

NpyDtype npy_dtype(const std::string& descr) {
  NpyDtype d;
  if (descr.size() != 3 || std::string("<>|=").find(descr[0]) == std::string::npos) return d;
  const char kind = descr[1];
  const std::size_t size = static_cast<std::size_t>(descr[2] - '0');
  const bool ok = (kind == 'b' && size == 1) || ((kind == 'u' || kind == 'i') && (size == 1 || size == 2 || size == 4 || size == 8)) ||
                  (kind == 'f' && (size == 4 || size == 8));
  if (!ok) return d;
  d.kind = kind, d.size = size, d.big_endian = descr[0] == '>';
  return d;
}

NpyHeader parse_header(const std::string& name, const std::uint8_t* bytes, std::size_t size) {
  auto fail = [&](const std::string& why) -> NpyHeader { throw Error("cannot read volume '" + name + "': " + why); };
  if (size == 0) fail("the file is empty");
  if (size < 8 || std::memcmp(bytes, "\x93NUMPY", 6) != 0) fail("not a .npy file (wrong magic)");
  const int major = bytes[6];
  std::size_t length = 0, prefix = 0;
  if (major == 1) {
    if (size < 10) fail("truncated header");
    length = bytes[8] | (bytes[9] << 8), prefix = 10;
  } else if (major == 2 || major == 3) {
    if (size < 12) fail("truncated header");
    length = bytes[8] | (bytes[9] << 8) | (bytes[10] << 16) | (static_cast<std::size_t>(bytes[11]) << 24), prefix = 12;
  } else {
    fail("unsupported .npy version " + std::to_string(major));
  }
  if (length > (1u << 20) || prefix + length > size) fail("truncated header (" + std::to_string(length) + " bytes declared)");
  const std::string dict(reinterpret_cast<const char*>(bytes) + prefix, length);
  NpyHeader h;
  h.data_offset = prefix + length;
  // A scan by hand, linear in the header's length: a recursive std::regex overflowed the stack
  // on a header holding a long string (issue 25).
  auto value_of = [&](const std::string& key) -> std::size_t {
    for (std::size_t at = dict.find("'" + key + "'"); at != std::string::npos; at = dict.find("'" + key + "'", at + 1)) {
      std::size_t p = at + key.size() + 2;
      while (p < dict.size() && std::isspace(static_cast<unsigned char>(dict[p]))) ++p;
      if (p < dict.size() && dict[p] == ':') {
        ++p;
        while (p < dict.size() && std::isspace(static_cast<unsigned char>(dict[p]))) ++p;
        return p;
      }
    }
    fail("no '" + key + "' in the header");
    return 0;
  };
  std::size_t p = value_of("descr");
  const std::size_t close = p < dict.size() && dict[p] == '\'' ? dict.find('\'', p + 1) : std::string::npos;
  if (close == std::string::npos || close - p > 16) fail("'descr' is not a dtype string");
  h.descr = dict.substr(p + 1, close - p - 1);
  p = value_of("fortran_order");
  if (dict.compare(p, 4, "True") == 0) h.fortran = true;
  else if (dict.compare(p, 5, "False") != 0) fail("'fortran_order' is neither True nor False");
  p = value_of("shape");
  if (p >= dict.size() || dict[p] != '(') fail("'shape' is not a tuple");
  const std::size_t shape_end = dict.find(')', p);
  if (shape_end == std::string::npos) fail("'shape' is not a tuple");
  for (++p; p < shape_end;) {
    while (p < shape_end && (std::isspace(static_cast<unsigned char>(dict[p])) || dict[p] == ',')) ++p;
    if (p == shape_end) break;
    std::size_t e = p;
    while (e < shape_end && std::isdigit(static_cast<unsigned char>(dict[e]))) ++e;
    const std::string d = dict.substr(p, std::max<std::size_t>(e - p, 1));
    if (e == p || e - p > 12) fail("the dimension '" + d.substr(0, 16) + "' is not a size");
    h.shape.push_back(std::stoll(d));
    p = e;
    while (p < shape_end && std::isspace(static_cast<unsigned char>(dict[p]))) ++p;
    if (p < shape_end && dict[p] != ',') fail("'shape' is not a tuple of sizes");
  }
  return h;
}

}  // namespace

namespace {
// The first bytes of a .npy file (its header: at most 1 MiB + 12) and the file's size, the size
// the header declares checked against the limit and the file before any voxel is read.
struct NpyHead {
  std::vector<std::uint8_t> bytes;
  std::uint64_t file_size = 0;
};
NpyHead npy_head(std::ifstream& in, const std::string& path, const VolumeOptions& o) {
  if (!in) throw Error("cannot read volume '" + path + "': cannot open the file (does it exist and is it readable?)");
  in.seekg(0, std::ios::end);
  NpyHead out;
  out.file_size = static_cast<std::uint64_t>(in.tellg());
  out.bytes.resize(static_cast<std::size_t>(std::min<std::uint64_t>(out.file_size, (1u << 20) + 12)));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(out.bytes.data()), static_cast<std::streamsize>(out.bytes.size()));
  const NpyHeader header = parse_header(path, out.bytes.data(), out.bytes.size());
  double voxels = 1;
  for (std::int64_t d : header.shape) voxels *= static_cast<double>(d);
  if (header.shape.size() == 3 && voxels > static_cast<double>(o.max_voxels))
    throw Error("cannot read volume '" + path + "': its " + detail::count_text(voxels) +
                " voxels are above the limit of " + std::to_string(o.max_voxels));
  const std::size_t declared = npy_dtype(header.descr).size, item = declared > 0 ? declared : 8;  // 8: the largest, when unknown
  if (static_cast<double>(out.file_size) > static_cast<double>(header.data_offset) + static_cast<double>(item) * std::max(voxels, 0.0) + 16)
    throw Error("cannot read volume '" + path + "': the file holds " + std::to_string(out.file_size) +
                " bytes, more than its header declares (" + detail::count_text(voxels) + " voxels of '" + header.descr + "')");
  return out;
}

// The whole .npy file in memory, its header checked against the limit before the data is read.
std::vector<std::uint8_t> npy_bytes(const std::string& path, const VolumeOptions& o) {
  std::ifstream in(path, std::ios::binary);
  const std::uint64_t file_size = npy_head(in, path, o).file_size;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(file_size));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (static_cast<std::uint64_t>(in.gcount()) != file_size) throw Error("cannot read volume '" + path + "': read error");
  return bytes;
}

// A .npy volume in memory as a grid of values, with its checks done: element [a, b, c] is voxel
// (i, j, k) = (c, b, a).
struct NpyGrid {
  const char* data = nullptr;
  NpyHeader header;
  NpyDtype dtype;
  std::string path;
  std::int64_t nx = 0, ny = 0, nz = 0;
  double h = 1;
  // The planes held at `data`: [plane0, plane0 + planes) of the first array axis (all of them
  // unless a slab was read), in the array's own order.
  std::int64_t plane0 = 0, planes = 0;
  double operator()(std::int64_t i, std::int64_t j, std::int64_t k) const {
    const std::int64_t a = k - plane0, b = j, c = i, n1 = header.shape[1], n2 = header.shape[2];
    const std::int64_t at = header.fortran ? a + planes * (b + n1 * c) : (a * n1 + b) * n2 + c;
    const auto* p = reinterpret_cast<const unsigned char*>(data) + dtype.size * static_cast<std::size_t>(at);
    std::uint64_t bits = 0;
    for (std::size_t q = 0; q < dtype.size; ++q)
      bits |= static_cast<std::uint64_t>(p[dtype.big_endian ? dtype.size - 1 - q : q]) << (8 * q);
    double value = 0;
    if (dtype.kind == 'f' && dtype.size == 4) {
      float f;
      const auto b32 = static_cast<std::uint32_t>(bits);
      std::memcpy(&f, &b32, 4);
      value = f;
    } else if (dtype.kind == 'f') {
      std::memcpy(&value, &bits, 8);
    } else if (dtype.kind == 'i') {
      const unsigned shift = static_cast<unsigned>(64 - 8 * dtype.size);  // sign-extend
      value = static_cast<double>(static_cast<std::int64_t>(bits << shift) >> shift);
    } else {
      value = static_cast<double>(bits);
    }
    if (std::isnan(value)) detail::refuse_nan_voxel(path, i, j, k);
    return value;
  }
};

// From the file's first `available` bytes (its header at least; the data follows it when
// available == file_size).
NpyGrid npy_grid(const std::uint8_t* bytes, std::size_t available, std::uint64_t file_size, const std::string& path,
                 const VolumeOptions& o) {
  auto fail = [&](const std::string& why) -> NpyGrid { throw Error("cannot read volume '" + path + "': " + why); };
  NpyGrid g;
  g.header = parse_header(path, bytes, available);
  const NpyHeader& header = g.header;
  g.dtype = npy_dtype(header.descr);
  g.path = path;
  if (g.dtype.kind == 0)
    fail("dtype '" + header.descr + "' is not supported (bool, integers of 1 to 8 bytes, float32 or float64)");
  if (header.shape.size() != 3) fail("a volume needs 3 dimensions, got " + std::to_string(header.shape.size()));
  double voxels = 1;
  for (std::int64_t d : header.shape) voxels *= static_cast<double>(d);
  if (voxels == 0) fail("the volume is empty (a dimension is 0)");
  if (voxels > static_cast<double>(o.max_voxels))
    fail("its " + detail::count_text(voxels) + " voxels are above the limit of " + std::to_string(o.max_voxels));
  if (static_cast<double>(header.data_offset) + voxels * static_cast<double>(g.dtype.size) > static_cast<double>(file_size))
    fail("truncated: the data holds " + std::to_string(file_size - header.data_offset) + " of " +
         detail::count_text(voxels * static_cast<double>(g.dtype.size)) + " bytes");
  if (!(o.h == 0 || (o.h > 0 && std::isfinite(o.h)))) require_positive("read_npy_volume: h", o.h);
  if (!std::isfinite(o.threshold)) fail("the threshold must be finite");
  // Axes as voxel counts along x, y, z: the last array axis is x in C order, the first in Fortran.
  g.nx = header.shape[2], g.ny = header.shape[1], g.nz = header.shape[0];
  if (std::max({g.nx, g.ny, g.nz}) > kMaxPixelIndex) fail("a dimension is above " + std::to_string(kMaxPixelIndex));
  g.data = reinterpret_cast<const char*>(bytes) + header.data_offset;
  g.planes = g.nz;
  g.h = o.h > 0 ? o.h : 1.0;  // voxel units by default: padding the array changes nothing (issue 25)
  return g;
}
}  // namespace

VoxelSet read_npy_volume(const std::string& path, const VolumeOptions& o) {
  const std::vector<std::uint8_t> bytes = npy_bytes(path, o);
  return decode_npy_volume(bytes.data(), bytes.size(), path, o);
}

VoxelSet decode_npy_volume(const std::uint8_t* bytes, std::size_t file_size, const std::string& path, const VolumeOptions& o) {
  const NpyGrid g = npy_grid(bytes, file_size, file_size, path, o);
  VoxelSet set = detail::voxel_set_from_grid(g.h, g.nx, g.ny, g.nz, [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return detail::is_foreground(o, g(i, j, k));
  });
  if (set.empty()) throw Error("cannot read volume '" + path + "': " + detail::no_foreground_reason(o));
  return set;
}

std::vector<LabelVoxels> read_npy_labels(const std::string& path, const VolumeOptions& o) {
  const std::vector<std::uint8_t> bytes = npy_bytes(path, o);
  const NpyGrid g = npy_grid(bytes.data(), bytes.size(), bytes.size(), path, o);
  return detail::label_sets_from_grid(path, g.h, g.nx, g.ny, g.nz, g);
}

namespace detail {
VolumeInfo npy_volume_info(const std::string& path, const VolumeOptions& o) {
  std::ifstream in(path, std::ios::binary);
  const NpyHead head = npy_head(in, path, o);
  const NpyGrid g = npy_grid(head.bytes.data(), head.bytes.size(), head.file_size, path, o);
  return {g.nx, g.ny, g.nz, g.h};
}

// Planes [k_begin, k_end) only: in C order one contiguous block (the first array axis is z), in
// Fortran order one block of k_end - k_begin elements per (y, x) pair.
VoxelSet read_npy_slab(const std::string& path, std::int64_t k_begin, std::int64_t k_end, const VolumeOptions& o) {
  std::ifstream in(path, std::ios::binary);
  const NpyHead head = npy_head(in, path, o);
  NpyGrid g = npy_grid(head.bytes.data(), head.bytes.size(), head.file_size, path, o);
  k_begin = std::clamp<std::int64_t>(k_begin, 0, g.nz), k_end = std::clamp<std::int64_t>(k_end, k_begin, g.nz);
  const std::int64_t planes = k_end - k_begin, n1 = g.header.shape[1], n2 = g.header.shape[2];
  const auto item = static_cast<std::int64_t>(g.dtype.size);
  std::vector<char> data(static_cast<std::size_t>(planes * n1 * n2 * item));
  auto read_at = [&](std::int64_t element, char* into, std::int64_t count) {
    in.seekg(static_cast<std::streamoff>(g.header.data_offset) + static_cast<std::streamoff>(element * item));
    in.read(into, static_cast<std::streamsize>(count * item));
    if (in.gcount() != static_cast<std::streamsize>(count * item)) throw Error("cannot read volume '" + path + "': read error");
  };
  if (planes > 0 && !g.header.fortran) {
    read_at(k_begin * n1 * n2, data.data(), planes * n1 * n2);
  } else if (planes > 0) {
    for (std::int64_t c = 0; c < n2; ++c)
      for (std::int64_t b = 0; b < n1; ++b)
        read_at(k_begin + g.nz * (b + n1 * c), data.data() + item * planes * (b + n1 * c), planes);
  }
  g.data = data.data(), g.plane0 = k_begin, g.planes = planes;
  return voxel_set_from_grid(g.h, g.nx, g.ny, planes, [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return is_foreground(o, g(i, j, k));
  }, k_begin);
}
}  // namespace detail

}  // namespace digilap::surface
