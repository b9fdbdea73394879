// Small text helpers shared by messages and tables.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace handscs {

// items[0] + sep + items[1] + ... ("" for no items).
inline std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? sep : "") + items[i];
  return out;
}

// A number for messages: up to 6 significant digits, exponent form when large or small
// (1e+30, 0.066, 1e-30), as a user would type it.
inline std::string number_text(double x) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", x);
  return text;
}

}  // namespace handscs
