// A compact binary encoding for caches: little-endian fixed-size values and length-prefixed
// strings appended to a byte string, read back with bounds checks. A read past the end, or a count
// larger than the bytes left, throws ByteStreamError: a truncated or foreign file is detected,
// never read as garbage or allowed to allocate without bound.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace handscs {

struct ByteStreamError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class ByteWriter {
 public:
  template <class T>
  void put(const T& value) {
    static_assert(std::is_arithmetic<T>::value, "put() takes numbers; strings use put_string()");
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  template <class T>
  void put_array(const T* values, size_t n) {
    static_assert(std::is_arithmetic<T>::value, "put_array() takes numbers");
    bytes_.append(reinterpret_cast<const char*>(values), n * sizeof(T));
  }
  void put_string(const std::string& text) {
    put<uint64_t>(text.size());
    bytes_.append(text);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class ByteReader {
 public:
  ByteReader(const char* data, size_t size) : data_(data), size_(size) {}

  template <class T>
  T get() {
    static_assert(std::is_arithmetic<T>::value, "get() reads numbers; strings use get_string()");
    T value;
    std::memcpy(&value, take(sizeof(T)), sizeof(T));
    return value;
  }
  template <class T>
  void get_array(T* values, size_t n) {
    static_assert(std::is_arithmetic<T>::value, "get_array() reads numbers");
    if (n > remaining() / sizeof(T)) throw ByteStreamError("truncated");
    std::memcpy(values, take(n * sizeof(T)), n * sizeof(T));
  }
  std::string get_string() {
    const uint64_t n = get<uint64_t>();
    if (n > remaining()) throw ByteStreamError("string longer than the data left");
    return std::string(take(n), n);
  }
  // A count of items of at least `min_item_bytes` each: no larger than the bytes left allow.
  uint64_t get_count(size_t min_item_bytes) {
    const uint64_t n = get<uint64_t>();
    if (min_item_bytes > 0 && n > remaining() / min_item_bytes)
      throw ByteStreamError("count " + std::to_string(n) + " exceeds the data left");
    return n;
  }
  size_t remaining() const { return size_ - position_; }

 private:
  const char* take(size_t n) {
    if (n > remaining()) throw ByteStreamError("truncated");
    const char* at = data_ + position_;
    position_ += n;
    return at;
  }
  const char* data_;
  size_t size_;
  size_t position_ = 0;
};

}  // namespace handscs
