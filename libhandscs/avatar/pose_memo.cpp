#include "avatar/pose_memo.h"

#include <algorithm>
#include <chrono>
#include <cstring>

#include "core/float_vector.h"

namespace handscs {

const AvatarState& PoseMemo::pose(const float* pose, const float* shape, const float* trans) {
  std::array<float, kKeySize> key;
  std::copy(pose, pose + 48, key.begin());
  std::copy(shape, shape + 10, key.begin() + 48);
  std::copy(trans, trans + 3, key.begin() + 58);
  // Bitwise comparison: -0.0 and 0.0 differ (harmlessly: one more decode), NaN is refused by
  // Avatar::pose before it could ever be stored.
  if (state_ && std::memcmp(key.data(), key_.data(), sizeof(float) * kKeySize) == 0) {
    ++reused_;
    return *state_;
  }
  const auto start = std::chrono::steady_clock::now();
  state_ = avatar_.pose(float_vector(key.data(), 48), float_vector(key.data() + 48, 10),
                        float_vector(key.data() + 58, 3));
  pose_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  key_ = key;
  ++computed_;
  return *state_;
}

}  // namespace handscs
