// Error type for user-facing failures (bad files, bad config, bad input data).
// Messages name the file and, where there is one, the key path: "configs/x.json: train.lr: ...".
#pragma once

#include <stdexcept>
#include <string>

namespace handscs {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

// Throws Error(message) when condition is false. For user input, not for programming errors.
inline void require(bool condition, const std::string& message) {
  if (!condition) throw Error(message);
}

}  // namespace handscs
