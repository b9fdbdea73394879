// Small text helpers shared by messages and tables.
#pragma once

#include <c10/util/ArrayRef.h>

#include <cctype>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace handscs {

// items[0] + sep + items[1] + ... ("" for no items).
inline std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? sep : "") + items[i];
  return out;
}

// A list for messages: "a, b, c", the first max_items only when longer ("a, b, ... (40 in all)"),
// so an error naming what a release holds stays one readable line.
inline std::string list_text(const std::vector<std::string>& items, size_t max_items = 12) {
  if (items.size() <= max_items) return join(items, ", ");
  const std::vector<std::string> head(items.begin(), items.begin() + max_items);
  return join(head, ", ") + ", ... (" + std::to_string(items.size()) + " in all)";
}

// A tensor or array shape for messages: "[778, 3, 10]" (a std::vector<int64_t> converts implicitly).
inline std::string shape_text(c10::IntArrayRef shape) {
  std::string text = "[";
  for (size_t i = 0; i < shape.size(); ++i) text += (i ? ", " : "") + std::to_string(shape[i]);
  return text + "]";
}

// A number for messages: up to 6 significant digits, exponent form when large or small
// (1e+30, 0.066, 1e-30), as a user would type it.
inline std::string number_text(double x) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", x);
  return text;
}

// A memory size for messages: "4.6 GB" from 1 GB up, "850 MB" below (decimal units).
inline std::string bytes_text(double bytes) {
  char text[32];
  if (bytes >= 1e9)
    std::snprintf(text, sizeof(text), "%.1f GB", bytes / 1e9);
  else
    std::snprintf(text, sizeof(text), "%.0f MB", bytes / 1e6);
  return text;
}

// True when `text` is 1 to max_digits decimal digits (no sign, no space).
inline bool all_digits(const std::string& text, size_t max_digits) {
  if (text.empty() || text.size() > max_digits) return false;
  for (const char c : text)
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  return true;
}

// A path's extension in lower case, with its dot (".JPG" -> ".jpg"; "" when it has none).
inline std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace handscs
