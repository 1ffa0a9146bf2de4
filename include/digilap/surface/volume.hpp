// digilap — volumes in: NumPy .npy arrays and NIfTI-1/2 files (a segmentation, a binary volume)
// as voxel sets, the 3D sibling of curve/image.hpp.
#pragma once

#include "digilap/surface/digitization.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace digilap::surface {

struct VolumeOptions {
  /// Grid step; 0 means: for NIfTI, the file's voxel spacing in its own unit (e.g. mm; 1 when the
  /// file gives none); for .npy, 1 (voxel units: padding the array changes nothing). NIfTI
  /// spacings must be equal within 1e-4 relative; with h given, within 1% (h overrides them).
  double h = 0.0;
  /// Foreground: value == label when label >= 0 (segmentations hold labels) ...
  std::int64_t label = -1;
  /// ... else value >= threshold (1: every non-zero voxel).
  double threshold = 1.0;
  /// Largest accepted number of voxels (checked from the header, before reading).
  std::int64_t max_voxels = 2'000'000'000;
};

/// Reads a 3-D .npy array (bool, uint8 or uint16, C or Fortran order). Element [a, b, c] is
/// voxel (i, j, k) = (c, b, a): the last axis is x, as in NumPy's (plane, row, column). Throws
/// digilap::Error naming the file and the reason for: a missing, empty or truncated file, a
/// wrong magic or header, a dtype or dimension that is not supported, a size above the limit,
/// a bad threshold or h.
VoxelSet read_npy_volume(const std::string& path, const VolumeOptions& options = {});
/// The same from bytes in memory (`name` is used in messages).
VoxelSet decode_npy_volume(const std::uint8_t* data, std::size_t size, const std::string& name = "volume",
                           const VolumeOptions& options = {});

/// Reads a NIfTI-1 or NIfTI-2 single file, .nii or .nii.gz, through nifticlib. Voxel (i, j, k)
/// is the file's index (i, j, k); the orientation matrices are not applied (a flip or rotation
/// does not change the operator's spectrum). Values are compared after scl_slope/scl_inter
/// when the file sets them. Integer and floating-point scalar types are read. Throws
/// digilap::Error naming the file and the reason for: a missing, empty, truncated or corrupt
/// file, a .hdr/.img pair, more than one volume (4-D), an unsupported data type, a size above
/// the limit, and anisotropic voxel spacing (named in the message: the operator assumes cubes,
/// resample first).
VoxelSet read_nifti_volume(const std::string& path, const VolumeOptions& options = {});

/// read_npy_volume or read_nifti_volume by the file's extension (.npy, .nii, .nii.gz).
VoxelSet read_volume(const std::string& path, const VolumeOptions& options = {});

/// A volume's grid from its header alone (no voxel read): voxels along x, y, z and the grid step
/// the readers use (VolumeOptions::h rules). Throws digilap::Error as read_volume does for a bad
/// header, size or spacing.
struct VolumeInfo {
  std::int64_t nx = 0, ny = 0, nz = 0;
  double h = 1.0;
};
VolumeInfo read_volume_info(const std::string& path, const VolumeOptions& options = {});

/// The planes k_begin <= k < k_end of a volume (clipped to [0, nz)), reading only their bytes (a
/// hyperslab: a rank of a distributed run reads its slab, never the whole file): exactly the
/// voxels of read_volume with k in that range, indices unchanged. An empty slab is no error (a
/// slab may miss the object). .npy in C order and .nii read one block; .npy in Fortran order one
/// block per (y, x) row; a .nii.gz is inflated from its start up to the slab.
VoxelSet read_volume_slab(const std::string& path, std::int64_t k_begin, std::int64_t k_end, const VolumeOptions& options = {});

/// One structure of a segmentation: its label and its voxels.
struct LabelVoxels {
  std::int64_t label = 0;
  VoxelSet voxels;
};

/// Every structure of a segmentation at once (the file read once, the grid swept once): one
/// voxel set per distinct non-zero value, labels ascending; options.label and threshold are not
/// used. Values within float rounding of an integer are that label (scl_slope products).
/// Throws digilap::Error as read_volume does, and for a value that is no integer label (naming
/// the voxel: a probability or intensity volume wants a threshold instead).
std::vector<LabelVoxels> read_labels(const std::string& path, const VolumeOptions& options = {});
/// The same for each format.
std::vector<LabelVoxels> read_nifti_labels(const std::string& path, const VolumeOptions& options = {});
std::vector<LabelVoxels> read_npy_labels(const std::string& path, const VolumeOptions& options = {});

}  // namespace digilap::surface
