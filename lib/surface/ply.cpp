#include "digilap/surface/ply.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <unordered_map>

namespace digilap::surface {

namespace {
// A corner in doubled integer coordinates, packed for hashing (|coordinate| < 2^21 here).
std::uint64_t key_of(const Eigen::Matrix<std::int64_t, 3, 1>& c) {
  auto part = [](std::int64_t v) { return static_cast<std::uint64_t>(v + (std::int64_t(1) << 20)) & ((1u << 21) - 1); };
  return part(c[0]) | (part(c[1]) << 21) | (part(c[2]) << 42);
}
}  // namespace

PlyMeshSize save_ply(const SurfelSet& surfels, const std::vector<std::pair<std::string, Eigen::VectorXd>>& fields,
                     const std::string& path) {
  for (const auto& [name, values] : fields) {
    if (values.size() != static_cast<Eigen::Index>(surfels.size()))
      throw Error("save_ply: field '" + name + "' has " + std::to_string(values.size()) + " values for " +
                  std::to_string(surfels.size()) + " surfels");
    if (name.empty() || !std::all_of(name.begin(), name.end(), [](unsigned char ch) { return std::isalnum(ch) || ch == '_'; }))
      throw Error("save_ply: field name '" + name + "' must be letters, digits and '_'");
  }
  // Corners: the surfel's centre +-1 along its two other axes, in doubled coordinates.
  std::unordered_map<std::uint64_t, std::int32_t> index;
  std::vector<float> xyz;
  std::vector<std::int32_t> quads(4 * surfels.size());
  for (std::size_t s = 0; s < surfels.size(); ++s) {
    const Surfel& f = surfels.surfels[s];
    Eigen::Matrix<std::int64_t, 3, 1> c = 2 * f.voxel.cast<std::int64_t>();
    if (c.cwiseAbs().maxCoeff() >= (std::int64_t(1) << 20) - 2) throw Error("save_ply: voxel indices beyond 2^19 are not supported");
    c[f.axis] += f.sign;
    const int u = (f.axis + 1) % 3, v = (f.axis + 2) % 3;
    const int du[4] = {-1, 1, 1, -1}, dv[4] = {-1, -1, 1, 1};  // counter-clockwise around e_u x e_v = e_axis
    for (int k = 0; k < 4; ++k) {
      const int corner = f.sign > 0 ? k : 3 - k;  // reversed when the outside is -e_axis
      Eigen::Matrix<std::int64_t, 3, 1> p = c;
      p[u] += du[corner];
      p[v] += dv[corner];
      const auto [it, fresh] = index.emplace(key_of(p), static_cast<std::int32_t>(xyz.size() / 3));
      if (fresh)
        for (int a = 0; a < 3; ++a) xyz.push_back(static_cast<float>(0.5 * surfels.h * static_cast<double>(p[a])));
      quads[4 * s + static_cast<std::size_t>(k)] = it->second;
    }
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error("cannot write '" + path + "' (check the directory exists and is writable)");
  out << "ply\nformat binary_little_endian 1.0\ncomment digilap surfels\nelement vertex " << xyz.size() / 3
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << surfels.size()
      << "\nproperty list uchar int vertex_indices\n";
  for (const auto& field : fields) out << "property float " << field.first << "\n";
  out << "end_header\n";
  out.write(reinterpret_cast<const char*>(xyz.data()), static_cast<std::streamsize>(xyz.size() * sizeof(float)));
  for (std::size_t s = 0; s < surfels.size(); ++s) {
    const unsigned char four = 4;
    out.write(reinterpret_cast<const char*>(&four), 1);
    out.write(reinterpret_cast<const char*>(&quads[4 * s]), 4 * sizeof(std::int32_t));
    for (const auto& field : fields) {
      const auto value = static_cast<float>(field.second[static_cast<Eigen::Index>(s)]);
      out.write(reinterpret_cast<const char*>(&value), sizeof value);
    }
  }
  if (!out) throw Error("error while writing '" + path + "' (disk full?)");
  return {xyz.size() / 3, surfels.size()};
}

}  // namespace digilap::surface
