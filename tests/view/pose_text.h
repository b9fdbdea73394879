// A POSES "pose" array as JSON text: the given leading values (any JSON text, also invalid ones),
// then zeros up to 48 numbers.
#pragma once

#include <string>
#include <vector>

namespace handscs_test {

inline std::string pose_text(const std::vector<std::string>& leading) {
  std::string text = "[";
  for (size_t i = 0; i < 48; ++i) text += (i ? "," : "") + (i < leading.size() ? leading[i] : std::string("0"));
  return text + "]";
}

}  // namespace handscs_test
