// A minimal .npz writer for tests: float64 arrays as np.savez stores them (a ZIP of .npy files,
// no compression). read_npz does not check CRCs, so they are written as 0; numpy would refuse them.
#pragma once

#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace data_test {

struct NpzArray {
  std::vector<int64_t> shape;
  std::vector<double> values;  // row-major
};

namespace npz_detail {
inline void put(std::string& out, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
}
// One .npy file, format version 1.0: magic, header length, a header padded to 64 bytes, data.
inline std::string npy(const NpzArray& a) {
  std::string shape;
  for (int64_t d : a.shape) shape += std::to_string(d) + ", ";
  if (a.shape.size() > 1) shape.resize(shape.size() - 1);
  std::string header = "{'descr': '<f8', 'fortran_order': False, 'shape': (" + shape + "), }";
  while ((10 + header.size() + 1) % 64 != 0) header.push_back(' ');
  header.push_back('\n');
  std::string out = "\x93NUMPY";
  out.push_back(1);
  out.push_back(0);
  put(out, header.size(), 2);
  out += header;
  const size_t at = out.size();
  out.resize(at + 8 * a.values.size());
  std::memcpy(&out[at], a.values.data(), 8 * a.values.size());
  return out;
}
}  // namespace npz_detail

// Writes `arrays` (by name, without ".npy") to `path` as an uncompressed ZIP.
inline void write_npz(const std::string& path, const std::map<std::string, NpzArray>& arrays) {
  using npz_detail::put;
  std::string body, directory;
  for (const auto& [name, array] : arrays) {
    const std::string file = name + ".npy", data = npz_detail::npy(array);
    const size_t offset = body.size();
    body += "PK\x03\x04";
    put(body, 20, 2);  // version needed
    put(body, 0, 2);   // flags
    put(body, 0, 2);   // method: stored
    put(body, 0, 4);   // time, date
    put(body, 0, 4);   // CRC-32 (not checked by read_npz)
    put(body, data.size(), 4);
    put(body, data.size(), 4);
    put(body, file.size(), 2);
    put(body, 0, 2);
    body += file + data;
    directory += "PK\x01\x02";
    put(directory, 20, 2);  // version made by
    put(directory, 20, 2);  // version needed
    put(directory, 0, 2);
    put(directory, 0, 2);
    put(directory, 0, 4);
    put(directory, 0, 4);
    put(directory, data.size(), 4);
    put(directory, data.size(), 4);
    put(directory, file.size(), 2);
    put(directory, 0, 2);  // extra length
    put(directory, 0, 2);  // comment length
    put(directory, 0, 2);  // disk
    put(directory, 0, 2);  // internal attributes
    put(directory, 0, 4);  // external attributes
    put(directory, offset, 4);
    directory += file;
  }
  std::string end = "PK\x05\x06";
  put(end, 0, 4);  // disk numbers
  put(end, arrays.size(), 2);
  put(end, arrays.size(), 2);
  put(end, directory.size(), 4);
  put(end, body.size(), 4);
  put(end, 0, 2);  // comment length
  std::ofstream(path, std::ios::binary) << body << directory << end;
}

}  // namespace data_test
