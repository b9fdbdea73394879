// Handedness from a rig's geometry (hand/rig_handedness.h): the built-in hand of each side forms
// the hand it is labelled, a mirror forms the other, a hand turned out of MANO's frame forms none,
// and load_rig warns about a file whose label its geometry contradicts (naming file, label, hand).
#include <ATen/ATen.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "hand/procedural_hand.h"
#include "hand/rig.h"
#include "hand/rig_handedness.h"
#include "hand/rig_mirror.h"

#include "captured_warnings.h"

#include "catch_after_torch.h"  // last: after c10's glog (see there)

using namespace handscs;
using handscs_test::CapturedWarnings;

namespace {

std::string handedness_dir() {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("handscs_handedness_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

}  // namespace

TEST_CASE("rig handedness: the built-in hands form the hands they are labelled, mirrors the "
          "other") {
  const Rig right = make_procedural_hand(Handedness::right);
  const Rig left = make_procedural_hand(Handedness::left);
  const GeometricHandedness right_geometry = geometric_handedness(right);
  const GeometricHandedness left_geometry = geometric_handedness(left);
  CHECK(right_geometry.hand == Handedness::right);
  CHECK(left_geometry.hand == Handedness::left);
  CHECK(right_geometry.cosine == Approx(0.977).margin(0.001));
  CHECK(left_geometry.cosine == Approx(-right_geometry.cosine).margin(1e-12));
  CHECK(handedness_disagreement(right, "r.json").empty());
  CHECK(handedness_disagreement(left, "l.json").empty());
  CHECK(geometric_handedness(mirror_rig(right)).hand == Handedness::left);
  CHECK(geometric_handedness(mirror_rig(left)).hand == Handedness::right);

  // Turning the hand about y (the back of the hand stays +y) keeps the answer: 180 degrees points
  // the fingers along +x, where a mirror would put them, and still forms a right hand.
  Rig turned = right;
  turned.v_template = right.v_template * torch::tensor({-1.0, 1.0, -1.0}, torch::kFloat64);
  CHECK(geometric_handedness(turned).hand == Handedness::right);

  // Back of the hand towards +z (90 degrees about x): no hand in MANO's frame, nothing to warn.
  turned.v_template = torch::stack({right.v_template.select(1, 0), -right.v_template.select(1, 2),
                                    right.v_template.select(1, 1)},
                                   1);
  const GeometricHandedness none = geometric_handedness(turned);
  CHECK_FALSE(none.hand.has_value());
  CHECK(std::abs(none.cosine) < kHandednessMinCosine);
  CHECK(handedness_disagreement(turned, "t.json").empty());
}

TEST_CASE("rig handedness: load_rig warns about a label its geometry contradicts") {
  const std::string dir = handedness_dir();
  for (const Handedness hand : {Handedness::right, Handedness::left}) {
    const Rig rig = make_procedural_hand(hand);
    const std::string label = hand == Handedness::right ? "right" : "left";
    const std::string other = hand == Handedness::right ? "left" : "right";
    const std::string side =
        hand == Handedness::right ? "+y, a right hand's back" : "-y, a left hand's palm";
    save_rig(rig, dir + "/" + label + ".json");
    Rig mislabelled = rig;
    mislabelled.handedness = hand == Handedness::right ? Handedness::left : Handedness::right;
    save_rig(mislabelled, dir + "/" + label + "_labelled_" + other + ".json");

    CapturedWarnings warnings;
    CHECK(load_rig(dir + "/" + label + ".json").handedness == hand);
    CHECK(warnings.messages().empty());
    const Rig loaded = load_rig(dir + "/" + label + "_labelled_" + other + ".json");
    CHECK(loaded.handedness == mislabelled.handedness);  // used as labelled
    CHECK(warnings.messages() ==
          std::vector<std::string>{dir + "/" + label + "_labelled_" + other +
                                   ".json: handedness: labelled \"" + other +
                                   "\", but the geometry is a " + label +
                                   " hand: its fingers (wrist to middle knuckle) x knuckle line "
                                   "(pinky to index) point to " + side +
                                   " in MANO's frame; the rig is used as labelled"});
  }
  std::filesystem::remove_all(dir);
}
