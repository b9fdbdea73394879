// Small text helpers shared by messages and tables.
#pragma once

#include <string>
#include <vector>

namespace handscs {

// items[0] + sep + items[1] + ... ("" for no items).
inline std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? sep : "") + items[i];
  return out;
}

}  // namespace handscs
