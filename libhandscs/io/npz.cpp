#include "io/npz.h"

#include <cstring>
#include <regex>

#include "core/atomic_file.h"
#include "core/error.h"

namespace handscs {

namespace {

// Camera archives hold a few kB; 1 GiB bounds what is read without refusing any real one.
constexpr std::uintmax_t kMaxNpzBytes = std::uintmax_t{1} << 30;

uint64_t little(const std::string& bytes, size_t at, int width, const std::string& where) {
  if (at + width > bytes.size()) throw Error(where + ": archive ends early (damaged ZIP)");
  uint64_t v = 0;
  for (int i = width - 1; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(bytes[at + i]);
  return v;
}

// The .npy payload of one entry -> array.
NpyArray parse_npy(const std::string& data, const std::string& where) {
  if (data.size() < 10 || data.compare(0, 6, "\x93NUMPY") != 0)
    throw Error(where + ": not a .npy array (magic string missing)");
  const int major = static_cast<unsigned char>(data[6]);
  const size_t header_len = major == 1 ? little(data, 8, 2, where) : little(data, 8, 4, where);
  const size_t start = (major == 1 ? 10 : 12) + header_len;
  if (start > data.size()) throw Error(where + ": .npy header runs past the entry");
  const std::string header = data.substr(major == 1 ? 10 : 12, header_len);
  std::smatch m;
  if (!std::regex_search(header, m, std::regex("'descr':\\s*'([^']*)'")))
    throw Error(where + ": .npy header has no descr");
  const std::string descr = m[1];
  const bool fortran = header.find("'fortran_order': True") != std::string::npos;
  if (!std::regex_search(header, m, std::regex("'shape':\\s*\\(([^)]*)\\)")))
    throw Error(where + ": .npy header has no shape");
  NpyArray array;
  const std::string dims = m[1];
  const std::regex digits("\\d+");
  for (std::sregex_iterator it(dims.begin(), dims.end(), digits), end; it != end; ++it)
    array.shape.push_back(std::stoll(it->str()));
  int64_t count = 1;
  for (int64_t d : array.shape) count *= d;
  int width = 0;
  if (descr == "<f8" || descr == "<i8" || descr == "<u8") width = 8;
  if (descr == "<f4" || descr == "<i4" || descr == "<u4") width = 4;
  if (width == 0)
    throw Error(where + ": dtype " + descr + " is not read (expected little-endian float or integer)");
  if (data.size() - start < static_cast<size_t>(count) * width)
    throw Error(where + ": .npy data shorter than its shape says");
  array.values.resize(count);
  const char* p = data.data() + start;
  for (int64_t i = 0; i < count; ++i, p += width) {
    if (descr == "<f8") { double v; std::memcpy(&v, p, 8); array.values[i] = v; }
    else if (descr == "<f4") { float v; std::memcpy(&v, p, 4); array.values[i] = v; }
    else if (descr == "<i8") { int64_t v; std::memcpy(&v, p, 8); array.values[i] = static_cast<double>(v); }
    else if (descr == "<u8") { uint64_t v; std::memcpy(&v, p, 8); array.values[i] = static_cast<double>(v); }
    else if (descr == "<i4") { int32_t v; std::memcpy(&v, p, 4); array.values[i] = v; }
    else { uint32_t v; std::memcpy(&v, p, 4); array.values[i] = v; }
  }
  if (fortran && array.shape.size() == 2) {  // column-major -> row-major
    std::vector<double> rows(count);
    const int64_t R = array.shape[0], C = array.shape[1];
    for (int64_t r = 0; r < R; ++r)
      for (int64_t c = 0; c < C; ++c) rows[r * C + c] = array.values[c * R + r];
    array.values = std::move(rows);
  } else if (fortran && array.shape.size() > 2) {
    throw Error(where + ": Fortran-order arrays of more than 2 dimensions are not read");
  }
  return array;
}

}  // namespace

std::map<std::string, NpyArray> read_npz(const std::string& path) {
  const std::string bytes = read_file(path, kMaxNpzBytes);
  // End of central directory: signature 0x06054b50 within the last 64 kB + 22 bytes.
  const size_t min_eocd = 22;
  if (bytes.size() < min_eocd) throw Error(path + ": not a ZIP archive (too short for an .npz)");
  size_t eocd = std::string::npos;
  for (size_t at = bytes.size() - min_eocd + 1; at-- > 0 && bytes.size() - at < 65536 + min_eocd;)
    if (little(bytes, at, 4, path) == 0x06054b50) {
      eocd = at;
      break;
    }
  if (eocd == std::string::npos) throw Error(path + ": not a ZIP archive (no end of central directory)");
  uint64_t entries = little(bytes, eocd + 10, 2, path);
  uint64_t directory = little(bytes, eocd + 16, 4, path);
  if (directory == 0xFFFFFFFF || entries == 0xFFFF) {
    // zip64: the locator just before the record points to the zip64 end record.
    if (eocd < 20 || little(bytes, eocd - 20, 4, path) != 0x07064b50)
      throw Error(path + ": zip64 archive without its locator (damaged ZIP)");
    const uint64_t record = little(bytes, eocd - 20 + 8, 8, path);
    if (little(bytes, record, 4, path) != 0x06064b50) throw Error(path + ": damaged zip64 record");
    entries = little(bytes, record + 32, 8, path);
    directory = little(bytes, record + 48, 8, path);
  }
  std::map<std::string, NpyArray> arrays;
  size_t at = directory;
  for (uint64_t e = 0; e < entries; ++e) {
    if (little(bytes, at, 4, path) != 0x02014b50) throw Error(path + ": damaged ZIP central directory");
    const uint64_t method = little(bytes, at + 10, 2, path);
    uint64_t size = little(bytes, at + 24, 4, path);
    uint64_t compressed = little(bytes, at + 20, 4, path);
    const size_t name_len = little(bytes, at + 28, 2, path), extra_len = little(bytes, at + 30, 2, path),
                 comment_len = little(bytes, at + 32, 2, path);
    uint64_t offset = little(bytes, at + 42, 4, path);
    if (at + 46 + name_len > bytes.size()) throw Error(path + ": damaged ZIP central directory");
    std::string name = bytes.substr(at + 46, name_len);
    // zip64 extra field (id 1): the 8-byte values of the fields that read 0xFFFFFFFF, in order.
    for (size_t x = at + 46 + name_len; x + 4 <= at + 46 + name_len + extra_len;) {
      const uint64_t id = little(bytes, x, 2, path), len = little(bytes, x + 2, 2, path);
      if (id == 1) {
        size_t f = x + 4;
        if (size == 0xFFFFFFFF) { size = little(bytes, f, 8, path); f += 8; }
        if (compressed == 0xFFFFFFFF) { compressed = little(bytes, f, 8, path); f += 8; }
        if (offset == 0xFFFFFFFF) offset = little(bytes, f, 8, path);
      }
      x += 4 + len;
    }
    at += 46 + name_len + extra_len + comment_len;
    const std::string where = path + ": " + name;
    if (method != 0)
      throw Error(where + ": compressed entry (np.savez_compressed); re-save the archive with np.savez");
    if (little(bytes, offset, 4, path) != 0x04034b50) throw Error(where + ": damaged local header");
    const size_t data_at = offset + 30 + little(bytes, offset + 26, 2, path) + little(bytes, offset + 28, 2, path);
    if (data_at + size > bytes.size()) throw Error(where + ": entry runs past the end of the file");
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0) name.resize(name.size() - 4);
    arrays[name] = parse_npy(bytes.substr(data_at, size), where);
  }
  return arrays;
}

}  // namespace handscs
