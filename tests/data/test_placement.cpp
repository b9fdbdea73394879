// data/placement.h: the hands a checkpoint records for a viewer without the run's capture.
#include <catch2/catch.hpp>

#include "data/placement.h"

namespace {

handscs::HandParams hand(float x) {
  handscs::HandParams h;
  h.pose[0] = x;
  h.shape[1] = x + 1;
  h.trans = {x, x + 2, x + 3};
  return h;
}

handscs::FrameInfo frame(const std::string& name, std::optional<handscs::HandParams> right,
                         std::optional<handscs::HandParams> left) {
  handscs::FrameInfo f;
  f.file_name = name;
  f.hands = {right, left};
  return f;
}

}  // namespace

TEST_CASE("placement: the first training frame holding every hand, as a POSES frame") {
  // Two hands: the first frame lacks the left hand, so the second, the first with both, is taken.
  const std::vector<handscs::FrameInfo> two = {frame("a.jpg", hand(1), std::nullopt), frame("b.jpg", hand(2), hand(3)),
                                               frame("c.jpg", hand(4), hand(5))};
  nlohmann::json p = handscs::training_placement(two);
  CHECK(p["name"] == "b.jpg");
  CHECK(p["right"] == handscs::hand_params_to_json(hand(2)));
  CHECK(p["left"] == handscs::hand_params_to_json(hand(3)));
  CHECK(p["left"]["trans"] == nlohmann::json::array({3.0, 5.0, 6.0}));
  CHECK(p.size() == 3);
  // No frame holds both: the first frame, with the hand it has.
  p = handscs::training_placement({frame("a.jpg", hand(1), std::nullopt), frame("b.jpg", std::nullopt, hand(3))});
  CHECK(p["name"] == "a.jpg");
  CHECK(p["right"] == handscs::hand_params_to_json(hand(1)));
  CHECK_FALSE(p.contains("left"));
  // One hand: the frame's own fields, no hand keys.
  handscs::FrameInfo one;
  one.file_name = "cam1/image0001.jpg";
  one.pose[5] = 0.25f;
  one.shape[0] = -1.5f;
  one.trans = {0.1f, 0.2f, 0.9f};
  p = handscs::training_placement({one});
  CHECK(p == nlohmann::json{{"pose", one.pose}, {"shape", one.shape}, {"trans", one.trans}, {"name", "cam1/image0001.jpg"}});
  CHECK_THROWS(handscs::training_placement({}));
}
