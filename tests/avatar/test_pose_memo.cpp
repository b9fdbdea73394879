// avatar/pose_memo.h: a repeated pose is answered from the previous result, a changed one (any of
// pose, shape, trans) is posed again, and every answer equals Avatar::pose on the same values.
#include "catch_torch.h"

#include <array>

#include <omp.h>

#include "avatar/pose_memo.h"
#include "core/threads.h"
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

TEST_CASE("pose memo: two hands posed side by side equal each posed alone, errors reach the caller") {
  handscs::Avatar right = handscs_test::small_double_avatar();
  handscs::Avatar left = handscs_test::small_double_avatar();
  c10::InferenceMode guard;
  const int threads = omp_get_max_threads();
  handscs::set_threads(2);  // the side-by-side path (it falls back to one after the other on one)
  handscs::PoseMemo memo_right(right), memo_left(left);
  torch::manual_seed(5);
  const torch::Tensor pose_r = torch::randn({48}) * 0.3, pose_l = torch::randn({48}) * 0.3;
  const torch::Tensor shape = torch::zeros({10});
  const torch::Tensor trans_r = torch::tensor({0.0f, 0.0f, 0.5f}), trans_l = torch::tensor({0.06f, 0.0f, 0.5f});
  const auto states = handscs::pose_side_by_side(
      {&memo_right, &memo_left},
      {handscs::HandPoseInput{pose_r.data_ptr<float>(), shape.data_ptr<float>(), trans_r.data_ptr<float>()},
       handscs::HandPoseInput{pose_l.data_ptr<float>(), shape.data_ptr<float>(), trans_l.data_ptr<float>()}});
  REQUIRE(states[0] != nullptr);
  REQUIRE(states[1] != nullptr);
  // Each worker ran under the caller's inference mode.
  CHECK(states[0]->posed.means.is_inference());
  CHECK(states[1]->posed.means.is_inference());
  // Double precision: one thread or two, the same values to rounding.
  CHECK(torch::allclose(states[0]->posed.means, right.pose(pose_r, shape, trans_r).posed.means, 0, 1e-12));
  CHECK(torch::allclose(states[1]->posed.colors, left.pose(pose_l, shape, trans_l).posed.colors, 0, 1e-12));
  // A skipped hand stays null; a hand whose pose is refused throws in the caller's thread.
  const auto one = handscs::pose_side_by_side(
      {&memo_right, &memo_left},
      {handscs::HandPoseInput{pose_r.data_ptr<float>(), shape.data_ptr<float>(), trans_r.data_ptr<float>()},
       handscs::HandPoseInput{}});
  CHECK(one[1] == nullptr);
  const torch::Tensor bad = pose_l.clone();
  bad[7] = std::nanf("");
  CHECK_THROWS_WITH(
      handscs::pose_side_by_side(
          {&memo_right, &memo_left},
          {handscs::HandPoseInput{pose_l.data_ptr<float>(), shape.data_ptr<float>(), trans_r.data_ptr<float>()},
           handscs::HandPoseInput{bad.data_ptr<float>(), shape.data_ptr<float>(), trans_l.data_ptr<float>()}}),
      Catch::Contains("NaN"));
  handscs::set_threads(threads);
}
