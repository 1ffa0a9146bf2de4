// libFuzzer target: volume readers (.npy from memory; NIfTI, plain or gzipped, through a file
// since nifticlib reads files) -> surfels -> II normals -> areas. Any input must give a result
// or a digilap::Error; anything else (a crash, a sanitizer report, another exception) is a bug.
// Built and run by scripts/fuzz.sh.
#include "digilap/core/error.hpp"
#include "digilap/surface/measures.hpp"
#include "digilap/surface/volume.hpp"

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

namespace {
digilap::surface::VoxelSet read(const std::uint8_t* data, std::size_t size, const digilap::surface::VolumeOptions& o) {
  if (size >= 6 && std::memcmp(data, "\x93NUMPY", 6) == 0) return digilap::surface::decode_npy_volume(data, size, "fuzz", o);
  const bool gz = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
  const std::string path = "/tmp/digilap-fuzz-" + std::to_string(getpid()) + (gz ? ".nii.gz" : ".nii");
  struct Removed {  // the file goes when the read ends, refused or not: no leftovers in /tmp
    const std::string& path;
    ~Removed() { std::remove(path.c_str()); }
  } removed{path};
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) __builtin_trap();
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  return digilap::surface::read_nifti_volume(path, o);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    digilap::surface::VolumeOptions o;
    o.max_voxels = 1 << 15;  // keep each run fast: 32^3 at most
    o.label = size % 3 == 0 ? 1 : -1;
    const digilap::surface::VoxelSet v = read(data, size, o);
    const digilap::surface::SurfelSet f = digilap::surface::extract_surfels(v);
    // Each voxel has 6 faces; the surfels are some of them, at least one per voxel row end.
    if (f.size() > 6 * static_cast<std::size_t>(v.voxel_count()) || f.size() < 2) __builtin_trap();
    const auto mu = digilap::surface::measures(f, digilap::surface::ii_normals(v, f, {1.0, 4 * v.h()}));
    if (!(mu.total_area() >= 0)) __builtin_trap();
  } catch (const digilap::Error&) {
    // A clear refusal is a correct answer.
  }
  return 0;
}
