// avatar/pose_memo.h: a repeated pose is answered from the previous result, a changed one (any of
// pose, shape, trans) is posed again, and every answer equals Avatar::pose on the same values.
#include "catch_torch.h"

#include <array>

#include "avatar/pose_memo.h"
#include "small_avatar.h"

namespace {

void check_equal_state(const handscs::AvatarState& a, const handscs::AvatarState& b) {
  CHECK(torch::equal(a.posed.means, b.posed.means));
  CHECK(torch::equal(a.posed.covariances, b.posed.covariances));
  CHECK(torch::equal(a.posed.colors, b.posed.colors));
  CHECK(torch::equal(a.posed.opacities, b.posed.opacities));
}

}  // namespace

TEST_CASE("pose memo: repeated poses are reused, changed ones posed again, all equal Avatar::pose") {
  handscs::Avatar avatar = handscs_test::small_double_avatar();
  c10::InferenceMode guard;
  handscs::PoseMemo memo(avatar);
  torch::manual_seed(3);
  std::array<float, 48> pose_a{}, pose_b{};
  std::array<float, 10> shape{};
  std::array<float, 3> trans{0.01f, -0.02f, 0.5f};
  const auto random_a = torch::randn({48}) * 0.3, random_b = torch::randn({48}) * 0.3;
  for (int k = 0; k < 48; ++k) {
    pose_a[k] = random_a[k].item<float>();
    pose_b[k] = random_b[k].item<float>();
  }
  auto direct = [&](const std::array<float, 48>& p, const std::array<float, 10>& s,
                    const std::array<float, 3>& t) {
    return avatar.pose(torch::tensor(std::vector<float>(p.begin(), p.end())),
                       torch::tensor(std::vector<float>(s.begin(), s.end())),
                       torch::tensor(std::vector<float>(t.begin(), t.end())));
  };

  const auto first = memo.pose(pose_a.data(), shape.data(), trans.data()).posed.means;
  check_equal_state(memo.pose(pose_a.data(), shape.data(), trans.data()), direct(pose_a, shape, trans));
  CHECK(memo.computed() == 1);
  CHECK(memo.reused() == 1);
  CHECK(memo.pose(pose_a.data(), shape.data(), trans.data()).posed.means.data_ptr() == first.data_ptr());

  check_equal_state(memo.pose(pose_b.data(), shape.data(), trans.data()), direct(pose_b, shape, trans));
  CHECK(memo.computed() == 2);
  shape[3] = 0.5f;  // the shape alone changes
  check_equal_state(memo.pose(pose_b.data(), shape.data(), trans.data()), direct(pose_b, shape, trans));
  trans[2] = 0.6f;  // the translation alone changes
  check_equal_state(memo.pose(pose_b.data(), shape.data(), trans.data()), direct(pose_b, shape, trans));
  CHECK(memo.computed() == 4);
  CHECK(memo.reused() == 2);
  CHECK(memo.pose_ms() > 0);
}
