// Internal: NumPy .npy arrays inside an uncompressed (stored) zip: the .npz layout that
// numpy.load and scipy.sparse.load_npz read. Written here because no Debian package writes
// .npz from C++; the format is small: a .npy is a magic, a Python-dict header padded to 64
// bytes and the raw little-endian array; a stored zip is a local header before each member
// and a central directory after them (CRC-32 by zlib), in ZIP64 form where a member or an
// offset reaches 4 GiB.
#pragma once

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace digilap::detail {

/// One array: its NumPy dtype ('<f8', '<i4', '<i8', '|S3'), shape, and bytes (C order).
struct NpyArray {
  std::string name;  ///< member name without ".npy"
  std::string dtype;
  std::vector<std::size_t> shape;
  const void* data = nullptr;
  std::size_t bytes = 0;
};

/// Writes the arrays as `path` (.npz, stored). Throws digilap::Error if it cannot be written.
void write_npz(const std::string& path, const std::vector<NpyArray>& arrays);

}  // namespace digilap::detail
