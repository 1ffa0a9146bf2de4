#include "npy_zip.hpp"

#include "digilap/core/error.hpp"

#include <zlib.h>

#include <cstdlib>
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

void put64(std::string& s, std::uint64_t v) {
  put32(s, static_cast<std::uint32_t>(v & 0xffffffffu));
  put32(s, static_cast<std::uint32_t>(v >> 32));
}

}  // namespace

void write_npz(const std::string& path, const std::vector<NpyArray>& arrays) {
  // ZIP64 (APPNOTE 4.5.3) for what a 32-bit field cannot hold: a member of 4 GiB or more, or one
  // starting beyond 4 GiB; then the 32-bit fields hold 0xFFFFFFFF and the real values sit in
  // the 0x0001 extra field, and a ZIP64 end record points at the central directory.
  // DIGILAP_ZIP64=1 writes every member so, which lets the tests read ZIP64 through NumPy
  // without writing 4 GiB.
  const char* force = std::getenv("DIGILAP_ZIP64");
  const std::uint64_t limit = force != nullptr && std::string(force) == "1" ? 0 : 0xFFFFFFFFull;
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error("cannot write '" + path + "' (check the directory exists and is writable)");
  std::string central;
  std::uint64_t offset = 0;
  bool any_zip64 = false;
  for (const NpyArray& a : arrays) {
    const std::string name = a.name + ".npy", header = npy_header(a);
    const std::uint64_t size = header.size() + a.bytes;
    const bool big = size >= limit, far = offset >= limit;
    any_zip64 = any_zip64 || big || far;
    const std::uint32_t crc = crc_of(crc_of(static_cast<std::uint32_t>(crc32(0, nullptr, 0)), header.data(), header.size()),
                                     a.data, a.bytes);
    const std::uint32_t size32 = big ? 0xFFFFFFFFu : static_cast<std::uint32_t>(size);
    const std::uint16_t version = big || far ? 45 : 20;  // 4.5: ZIP64
    // Local file header: stored (method 0), no data descriptor, DOS time 1980-01-01.
    std::string local;
    put32(local, 0x04034b50);
    put16(local, version);  // version needed
    put16(local, 0);        // flags
    put16(local, 0);        // stored
    put16(local, 0);        // time
    put16(local, 0x21);     // date: 1980-01-01
    put32(local, crc);
    put32(local, size32);
    put32(local, size32);
    put16(local, static_cast<std::uint32_t>(name.size()));
    put16(local, big ? 20 : 0);  // extra: the ZIP64 sizes
    local += name;
    if (big) {
      put16(local, 0x0001), put16(local, 16);
      put64(local, size), put64(local, size);
    }
    out.write(local.data(), static_cast<std::streamsize>(local.size()));
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    out.write(static_cast<const char*>(a.data), static_cast<std::streamsize>(a.bytes));
    // Its central directory entry: the ZIP64 extra holds, in this order, the sizes (when
    // big) and the local header's offset (when far).
    std::string extra;
    if (big) put64(extra, size), put64(extra, size);
    if (far) put64(extra, offset);
    put32(central, 0x02014b50);
    put16(central, version);  // made by
    put16(central, version);  // needed
    put16(central, 0);
    put16(central, 0);
    put16(central, 0);
    put16(central, 0x21);
    put32(central, crc);
    put32(central, size32);
    put32(central, size32);
    put16(central, static_cast<std::uint32_t>(name.size()));
    put16(central, static_cast<std::uint32_t>(extra.empty() ? 0 : extra.size() + 4));
    put16(central, 0);  // comment
    put16(central, 0);  // disk
    put16(central, 0);  // internal attributes
    put32(central, 0);  // external attributes
    put32(central, far ? 0xFFFFFFFFu : static_cast<std::uint32_t>(offset));
    central += name;
    if (!extra.empty()) {
      put16(central, 0x0001), put16(central, static_cast<std::uint32_t>(extra.size()));
      central += extra;
    }
    offset += local.size() + size;
  }
  std::string end;
  const bool zip64_end = any_zip64 || offset >= limit || central.size() >= limit;
  if (zip64_end) {
    // ZIP64 end of central directory record and its locator, before the classic end record.
    const std::uint64_t record_at = offset + central.size();
    put32(end, 0x06064b50);
    put64(end, 44);  // size of the rest of this record
    put16(end, 45), put16(end, 45);
    put32(end, 0), put32(end, 0);  // this disk, the directory's disk
    put64(end, arrays.size()), put64(end, arrays.size());
    put64(end, central.size());
    put64(end, offset);
    put32(end, 0x07064b50);
    put32(end, 0);
    put64(end, record_at);
    put32(end, 1);  // disks
  }
  put32(end, 0x06054b50);
  put16(end, 0);
  put16(end, 0);
  put16(end, static_cast<std::uint32_t>(arrays.size()));
  put16(end, static_cast<std::uint32_t>(arrays.size()));
  put32(end, zip64_end ? 0xFFFFFFFFu : static_cast<std::uint32_t>(central.size()));
  put32(end, zip64_end ? 0xFFFFFFFFu : static_cast<std::uint32_t>(offset));
  put16(end, 0);
  out.write(central.data(), static_cast<std::streamsize>(central.size()));
  out.write(end.data(), static_cast<std::streamsize>(end.size()));
  if (!out) throw Error("error while writing '" + path + "' (disk full?)");
}

}  // namespace digilap::detail
