// libFuzzer target: .npy volume reader -> surfels -> II normals -> areas. Any input must give a
// result or a digilap::Error; anything else (a crash, a sanitizer report, another exception) is
// a bug. Built and run by scripts/fuzz.sh.
#include "digilap/error.hpp"
#include "digilap/surface/measures.hpp"
#include "digilap/surface/volume.hpp"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    digilap::surface::VolumeOptions o;
    o.max_voxels = 1 << 15;  // keep each run fast: 32^3 at most
    o.label = size % 3 == 0 ? 1 : -1;
    const digilap::surface::VoxelSet v = digilap::surface::decode_npy_volume(data, size, "fuzz", o);
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
