#include "npy_zip.hpp"

#include "digilap/error.hpp"

#include <zlib.h>

#include <limits>

namespace digilap::detail {

namespace {

// The .npy header (format 1.0): magic, version, header length, then the dict, padded with
// spaces and a newline so that the data starts at a multiple of 64 bytes.
std::string npy_header(const NpyArray& a) {
  std::string shape;  // Python's tuple syntax: (), (3,), (3, 2)
  for (std::size_t d : a.shape) shape += (shape.empty() ? "" : ", ") + std::to_string(d);
  shape = "(" + shape + (a.shape.size() == 1 ? ",)" : ")");
  std::string dict = "{'descr': '" + a.dtype + "', 'fortran_order': False, 'shape': " + shape + ", }";
  const std::size_t unpadded = 10 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  std::string header("\x93NUMPY\x01\x00", 8);
  header += static_cast<char>(dict.size() & 0xff);
  header += static_cast<char>((dict.size() >> 8) & 0xff);
  return header + dict;
}

void put16(std::string& s, std::uint32_t v) {
  s += static_cast<char>(v & 0xff);
  s += static_cast<char>((v >> 8) & 0xff);
}
void put32(std::string& s, std::uint32_t v) {
  put16(s, v & 0xffff);
  put16(s, v >> 16);
}

// CRC-32 of a large buffer, by zlib, in pieces its uInt length can hold.
std::uint32_t crc_of(std::uint32_t crc, const void* data, std::size_t bytes) {
  const auto* p = static_cast<const Bytef*>(data);
  while (bytes > 0) {
    const auto piece = static_cast<uInt>(std::min<std::size_t>(bytes, 1u << 30));
    crc = static_cast<std::uint32_t>(crc32(crc, p, piece));
    p += piece;
    bytes -= piece;
  }
  return crc;
}

}  // namespace

void write_npz(const std::string& path, const std::vector<NpyArray>& arrays) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error("cannot write '" + path + "' (check the directory exists and is writable)");
  std::string central;
  std::uint64_t offset = 0;
  for (const NpyArray& a : arrays) {
    const std::string name = a.name + ".npy", header = npy_header(a);
    const std::uint64_t size = header.size() + a.bytes;
    if (size >= std::numeric_limits<std::uint32_t>::max() || offset >= std::numeric_limits<std::uint32_t>::max())
      throw Error("cannot write '" + path + "': member '" + name + "' would reach 4 GiB (a ZIP64 archive); " +
                  "write Matrix Market files instead, or a coarser h");
    const std::uint32_t crc = crc_of(crc_of(static_cast<std::uint32_t>(crc32(0, nullptr, 0)), header.data(), header.size()),
                                     a.data, a.bytes);
    // Local file header: stored (method 0), no data descriptor, DOS time 1980-01-01.
    std::string local;
    put32(local, 0x04034b50);
    put16(local, 20);  // version needed: 2.0
    put16(local, 0);   // flags
    put16(local, 0);   // stored
    put16(local, 0);   // time
    put16(local, 0x21);  // date: 1980-01-01
    put32(local, crc);
    put32(local, static_cast<std::uint32_t>(size));
    put32(local, static_cast<std::uint32_t>(size));
    put16(local, static_cast<std::uint32_t>(name.size()));
    put16(local, 0);
    local += name;
    out.write(local.data(), static_cast<std::streamsize>(local.size()));
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    out.write(static_cast<const char*>(a.data), static_cast<std::streamsize>(a.bytes));
    // Its central directory entry.
    put32(central, 0x02014b50);
    put16(central, 20);  // made by
    put16(central, 20);  // needed
    put16(central, 0);
    put16(central, 0);
    put16(central, 0);
    put16(central, 0x21);
    put32(central, crc);
    put32(central, static_cast<std::uint32_t>(size));
    put32(central, static_cast<std::uint32_t>(size));
    put16(central, static_cast<std::uint32_t>(name.size()));
    put16(central, 0);  // extra
    put16(central, 0);  // comment
    put16(central, 0);  // disk
    put16(central, 0);  // internal attributes
    put32(central, 0);  // external attributes
    put32(central, static_cast<std::uint32_t>(offset));
    central += name;
    offset += local.size() + size;
  }
  if (offset >= std::numeric_limits<std::uint32_t>::max())
    throw Error("cannot write '" + path + "': the archive would reach 4 GiB (a ZIP64 archive)");
  std::string end;
  put32(end, 0x06054b50);
  put16(end, 0);
  put16(end, 0);
  put16(end, static_cast<std::uint32_t>(arrays.size()));
  put16(end, static_cast<std::uint32_t>(arrays.size()));
  put32(end, static_cast<std::uint32_t>(central.size()));
  put32(end, static_cast<std::uint32_t>(offset));
  put16(end, 0);
  out.write(central.data(), static_cast<std::streamsize>(central.size()));
  out.write(end.data(), static_cast<std::streamsize>(end.size()));
  if (!out) throw Error("error while writing '" + path + "' (disk full?)");
}

}  // namespace digilap::detail
