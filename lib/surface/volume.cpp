#include "digilap/surface/volume.hpp"

#include "digilap/error.hpp"
#include "volume_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <regex>
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
  std::smatch m;
  if (!std::regex_search(dict, m, std::regex(R"('descr'\s*:\s*'([^']*)')"))) fail("no 'descr' in the header");
  h.descr = m[1];
  if (!std::regex_search(dict, m, std::regex(R"('fortran_order'\s*:\s*(True|False))"))) fail("no 'fortran_order' in the header");
  h.fortran = m[1] == "True";
  if (!std::regex_search(dict, m, std::regex(R"('shape'\s*:\s*\(([^)]*)\))"))) fail("no 'shape' in the header");
  const std::string dims = m[1];
  const std::regex number(R"(-?\d+)");
  for (std::sregex_iterator it(dims.begin(), dims.end(), number), end; it != end; ++it) {
    const std::string d = it->str();
    if (d.size() > 12 || d[0] == '-') fail("the dimension '" + d + "' is not a size");
    h.shape.push_back(std::stoll(d));
  }
  return h;
}

}  // namespace

namespace {
// The whole .npy file in memory, its header checked against the limit before the data is read.
std::vector<std::uint8_t> npy_bytes(const std::string& path, const VolumeOptions& o) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw Error("cannot read volume '" + path + "': cannot open the file (does it exist and is it readable?)");
  const auto file_size = static_cast<std::uint64_t>(in.tellg());
  // The header first: the size it declares is checked against the limit before reading more.
  std::vector<std::uint8_t> head(static_cast<std::size_t>(std::min<std::uint64_t>(file_size, (1u << 20) + 12)));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
  const NpyHeader header = parse_header(path, head.data(), head.size());
  double voxels = 1;
  for (std::int64_t d : header.shape) voxels *= static_cast<double>(d);
  if (header.shape.size() == 3 && voxels > static_cast<double>(o.max_voxels))
    throw Error("cannot read volume '" + path + "': its " + detail::count_text(voxels) +
                " voxels are above the limit of " + std::to_string(o.max_voxels));
  if (file_size > static_cast<std::uint64_t>(header.data_offset) + 2 * static_cast<std::uint64_t>(std::max(voxels, 0.0)) + 16)
    throw Error("cannot read volume '" + path + "': the file is larger than its header declares");
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
  std::size_t item = 0;
  std::int64_t nx = 0, ny = 0, nz = 0;
  double h = 1;
  double operator()(std::int64_t i, std::int64_t j, std::int64_t k) const {
    const std::int64_t a = k, b = j, c = i, n0 = header.shape[0], n1 = header.shape[1], n2 = header.shape[2];
    const std::int64_t at = header.fortran ? a + n0 * (b + n1 * c) : (a * n1 + b) * n2 + c;
    if (item == 1) return static_cast<unsigned char>(data[static_cast<std::size_t>(at)]);
    const auto* p = reinterpret_cast<const unsigned char*>(data) + 2 * at;
    return p[0] | (p[1] << 8);
  }
};

NpyGrid npy_grid(const std::uint8_t* bytes, std::size_t file_size, const std::string& path, const VolumeOptions& o) {
  auto fail = [&](const std::string& why) -> NpyGrid { throw Error("cannot read volume '" + path + "': " + why); };
  NpyGrid g;
  g.header = parse_header(path, bytes, file_size);
  const NpyHeader& header = g.header;
  if (header.descr == "|b1" || header.descr == "|u1" || header.descr == "<u1") g.item = 1;
  else if (header.descr == "<u2") g.item = 2;
  else fail("dtype '" + header.descr + "' is not supported (bool, uint8 or uint16)");
  if (header.shape.size() != 3) fail("a volume needs 3 dimensions, got " + std::to_string(header.shape.size()));
  double voxels = 1;
  for (std::int64_t d : header.shape) voxels *= static_cast<double>(d);
  if (voxels == 0) fail("the volume is empty (a dimension is 0)");
  if (voxels > static_cast<double>(o.max_voxels))
    fail("its " + detail::count_text(voxels) + " voxels are above the limit of " + std::to_string(o.max_voxels));
  if (static_cast<double>(header.data_offset) + voxels * static_cast<double>(g.item) > static_cast<double>(file_size))
    fail("truncated: the data holds " + std::to_string(file_size - header.data_offset) + " of " +
         detail::count_text(voxels * static_cast<double>(g.item)) + " bytes");
  if (!(o.h == 0 || (o.h > 0 && std::isfinite(o.h)))) require_positive("read_npy_volume: h", o.h);
  if (!std::isfinite(o.threshold)) fail("the threshold must be finite");
  // Axes as voxel counts along x, y, z: the last array axis is x in C order, the first in Fortran.
  g.nx = header.shape[2], g.ny = header.shape[1], g.nz = header.shape[0];
  if (std::max({g.nx, g.ny, g.nz}) > kMaxPixelIndex) fail("a dimension is above " + std::to_string(kMaxPixelIndex));
  g.data = reinterpret_cast<const char*>(bytes) + header.data_offset;
  g.h = o.h > 0 ? o.h : 1.0 / static_cast<double>(std::max({g.nx, g.ny, g.nz}));
  return g;
}
}  // namespace

VoxelSet read_npy_volume(const std::string& path, const VolumeOptions& o) {
  const std::vector<std::uint8_t> bytes = npy_bytes(path, o);
  return decode_npy_volume(bytes.data(), bytes.size(), path, o);
}

VoxelSet decode_npy_volume(const std::uint8_t* bytes, std::size_t file_size, const std::string& path, const VolumeOptions& o) {
  const NpyGrid g = npy_grid(bytes, file_size, path, o);
  VoxelSet set = detail::voxel_set_from_grid(g.h, g.nx, g.ny, g.nz, [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return detail::is_foreground(o, g(i, j, k));
  });
  if (set.empty()) throw Error("cannot read volume '" + path + "': " + detail::no_foreground_reason(o));
  return set;
}

std::vector<LabelVoxels> read_npy_labels(const std::string& path, const VolumeOptions& o) {
  const std::vector<std::uint8_t> bytes = npy_bytes(path, o);
  const NpyGrid g = npy_grid(bytes.data(), bytes.size(), path, o);
  return detail::label_sets_from_grid(path, g.h, g.nx, g.ny, g.nz, g);
}

}  // namespace digilap::surface
