// Every bad annotation input gives an error naming the file and the key path (exact texts).
#include <nlohmann/json.hpp>

#include "core/camera_checks.h"
#include "data/interhand_annotations.h"
#include "data/json_view.h"
#include "data_test_helpers.h"

// Catch last: LibTorch pulls in glog, whose CHECK macro would otherwise replace Catch's.
#include <catch2/catch.hpp>

using namespace handscs;
using data_test::error_of;
using nlohmann::json;

namespace {

json valid_data() {
  json image = {{"id", 5},           {"file_name", "Capture0/seq/cam400002/image7.jpg"},
                {"width", 334},      {"height", 512},
                {"capture", 0},      {"subject", 0},
                {"seq_name", "seq"}, {"camera", "400002"},
                {"frame_idx", 7}};
  json valid = json::array();
  for (int j = 0; j < 42; ++j) valid.push_back(json::array({j < 21 ? 1 : 0}));
  json annotation = {{"id", 5},
                     {"image_id", 5},
                     {"bbox", {1, 2, 3, 4}},
                     {"joint_valid", valid},
                     {"hand_type", "right"},
                     {"hand_type_valid", 1}};
  return {{"images", {image}}, {"annotations", {annotation}}};
}

json valid_cameras() {
  return {{"0",
           {{"campos", {{"400002", {1.0, 2.0, 3.0}}}},
            {"camrot", {{"400002", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}}},
            {"focal", {{"400002", {1200.0, 1201.0}}}},
            {"princpt", {{"400002", {160.0, 250.0}}}}}}};
}

json valid_joints() {
  json coords = json::array();
  json valid = json::array();
  for (int j = 0; j < 42; ++j) {
    coords.push_back({1.0 * j, 2.0, 1000.0});
    valid.push_back(json::array({true}));
  }
  return {{"0",
           {{"7",
             {{"world_coord", coords},
              {"joint_valid", valid},
              {"hand_type", "right"},
              {"hand_type_valid", true}}}}}};
}

json valid_mano() {
  json hand = {{"pose", std::vector<double>(48, 0.1)},
               {"shape", std::vector<double>(10, 0.0)},
               {"trans", {0.0, 0.1, 1.0}}};
  return {{"0", {{"7", {{"right", hand}, {"left", nullptr}}}}}};
}

std::string file(const std::string& name, const json& value) {
  static const std::string dir = data_test::fresh_dir("annotation_errors");
  return data_test::write_text(dir + "/" + name, value.dump(1));
}

}  // namespace

TEST_CASE("annotation errors: valid minimal files parse") {
  const auto images = read_interhand_images(file("data.json", valid_data()), {});
  REQUIRE(images.size() == 1);
  CHECK(images[0].joint_valid[20] == 1);
  CHECK(images[0].joint_valid[21] == 0);
  CHECK(images[0].hand_type_valid);
  const auto cameras = read_interhand_cameras(file("camera.json", valid_cameras()), 0);
  REQUIRE(cameras.count("400002"));
  const Camera camera = camera_from_interhand(cameras.at("400002"), 334, 512);
  CHECK(camera.t[0] == Approx(-0.001));
  CHECK(camera.t[2] == Approx(-0.003));
  CHECK(camera.fy() == 1201.0);
  CHECK(camera.cy() == 250.0);
  const auto joints = read_interhand_joints(file("joint_3d.json", valid_joints()), 0);
  CHECK(joints.at(7).world_mm[3] == 1.0);
  const auto mano = read_interhand_mano(file("mano.json", valid_mano()), 0);
  REQUIRE(mano.at(7).right.has_value());
  CHECK_FALSE(mano.at(7).left.has_value());
  CHECK(mano.at(7).right->trans[2] == 1.0);
}

TEST_CASE("annotation errors: malformed JSON names file, line and column") {
  const std::string path = data_test::write_text(data_test::fresh_dir("malformed") + "/data.json",
                                                 "{\n  \"images\": [\n    {\"id\": 5,,}\n");
  const std::string message = error_of([&] { read_interhand_images(path, {}); });
  CHECK(message.rfind(path + ": malformed JSON at line 3, column 14 (", 0) == 0);
  const std::string missing = "/nonexistent/InterHand2.6M_test_data.json";
  CHECK(error_of([&] { read_interhand_images(missing, {}); }) == missing + ": cannot open file");
}

TEST_CASE("annotation errors: data.json missing keys and wrong shapes") {
  json d = valid_data();
  d["images"][0].erase("camera");
  std::string p = file("d1.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": images[0]: missing key \"camera\"");

  d = valid_data();
  d["images"][0]["camera"] = 400002;
  p = file("d2.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": images[0].camera: expected string, got number");

  d = valid_data();
  d["annotations"][0]["bbox"] = {1, 2, 3};
  p = file("d3.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": annotations[0].bbox: expected array of 4, got array of 3");

  d = valid_data();
  d["annotations"][0]["joint_valid"].erase(0);
  p = file("d4.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": annotations[0].joint_valid: expected array of 42, got array of 41");

  d = valid_data();
  d["annotations"][0]["joint_valid"][3] = {2};
  p = file("d5.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": annotations[0].joint_valid[3][0]: expected 0 or 1, got 2");

  d = valid_data();
  d["annotations"][0]["image_id"] = 6;
  p = file("d6.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": annotations: no entry for image_id 5 (Capture0/seq/cam400002/image7.jpg)");

  d = valid_data();
  d.erase("annotations");
  p = file("d7.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": (top level): missing key \"annotations\"");

  d = valid_data();
  d["images"] = {{"x", 1}};
  p = file("d8.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": images: expected array, got object");

  p = file("d9.json", json::array({1, 2}));
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": (top level): expected object, got array of 2");

  d = valid_data();
  d["images"][0]["frame_idx"] = 7.5;
  p = file("d10.json", d);
  CHECK(error_of([&] { read_interhand_images(p, {}); }) ==
        p + ": images[0].frame_idx: expected integer, got 7.5");
  // Paths leaving the images folder, duplicate image ids and duplicate annotations.
  for (const char* bad : {"../../../../etc/passwd", "/etc/passwd", "Capture0/../../x.jpg"}) {
    json escaping = valid_data();
    escaping["images"][0]["file_name"] = bad;
    const std::string path = file("d_escape.json", escaping);
    CHECK(error_of([&] { read_interhand_images(path, {}); }) ==
          path + ": images[0].file_name: \"" + bad +
              "\" is not a relative path inside the images folder (absolute, or has ..)");
  }
  json twice = valid_data();
  twice["images"].push_back(twice["images"][0]);
  twice["images"][1]["file_name"] = "Capture0/seq/cam400002/image8.jpg";
  std::string dup = file("d_dup_id.json", twice);
  CHECK(error_of([&] { read_interhand_images(dup, {}); }) == dup + ": images[1].id: duplicate image id 5");
  twice = valid_data();
  twice["annotations"].push_back(twice["annotations"][0]);
  dup = file("d_dup_annotation.json", twice);
  CHECK(error_of([&] { read_interhand_images(dup, {}); }) ==
        dup + ": annotations[1].image_id: second annotation for image_id 5");
}

TEST_CASE("camera checks: implausible intrinsics and sizes are named") {
  Camera camera;
  camera.width = 334;
  camera.height = 512;
  camera.K = {1200, 0, 160, 0, 1200, 250, 0, 0, 1};  // an InterHand2.6M camera
  CHECK(camera_intrinsics_problem(camera).empty());
  camera.K[0] = 1e-30;
  CHECK(camera_intrinsics_problem(camera) ==
        "fx = 1e-30 is 2.99401e-33 image widths: outside the plausible 0.04-120 (fields of view of 170 to 0.5 "
        "degrees)");
  camera.K[0] = 1e30;
  CHECK(camera_intrinsics_problem(camera).rfind("fx = 1e+30 is ", 0) == 0);
  camera.K[0] = 1200;
  camera.K[2] = 1e12;
  CHECK(camera_intrinsics_problem(camera) ==
        "cx = 1e+12 lies more than 1 image width outside the image (0-334)");
  camera.K[2] = 160;
  camera.width = camera.height = 30000;
  CHECK(camera_intrinsics_problem(camera) == "image of 30000x30000 = 900 megapixels exceeds the 100 megapixel limit");
}

TEST_CASE("annotation errors: camera.json missing capture, keys and wrong shapes") {
  std::string p = file("c0.json", valid_cameras());
  CHECK(error_of([&] { read_interhand_cameras(p, 3); }) == p + ": (top level): missing key \"3\"");

  json c = valid_cameras();
  c["0"]["camrot"]["400002"][1] = {0, 1};
  p = file("c1.json", c);
  CHECK(error_of([&] { read_interhand_cameras(p, 0); }) ==
        p + ": 0.camrot.400002[1]: expected array of 3, got array of 2");
  // An all-zero rotation (reported as "hand outside image") is named.
  c = valid_cameras();
  c["0"]["camrot"]["400002"] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  p = file("c_zero_rot.json", c);
  CHECK(error_of([&] { read_interhand_cameras(p, 0); }) ==
        p + ": 0.camrot.400002: not a rotation matrix (R R^T != I or det < 0)");

  c = valid_cameras();
  c["0"]["focal"].erase("400002");
  p = file("c2.json", c);
  CHECK(error_of([&] { read_interhand_cameras(p, 0); }) == p + ": 0.focal: missing key \"400002\"");

  c = valid_cameras();
  c["0"].erase("princpt");
  p = file("c3.json", c);
  CHECK(error_of([&] { read_interhand_cameras(p, 0); }) == p + ": 0: missing key \"princpt\"");

  c = valid_cameras();
  c["0"]["campos"]["400002"] = {1.0, "2", 3.0};
  p = file("c4.json", c);
  CHECK(error_of([&] { read_interhand_cameras(p, 0); }) ==
        p + ": 0.campos.400002[1]: expected number, got string");

  c = valid_cameras();
  c["0"]["focal"]["400002"] = {0.0, 1200.0};
  p = file("c5.json", c);
  CHECK(error_of([&] { read_interhand_cameras(p, 0); }) ==
        p + ": 0.focal.400002: focal lengths must be positive");
}

TEST_CASE("annotation errors: joint_3d.json wrong shapes and keys") {
  json j = valid_joints();
  j["0"]["7"]["world_coord"].erase(0);
  std::string p = file("j1.json", j);
  CHECK(error_of([&] { read_interhand_joints(p, 0); }) ==
        p + ": 0.7.world_coord: expected 42x3 array, got array of 41");

  j = valid_joints();
  j["0"]["7"]["world_coord"][4] = {1.0, 2.0};
  p = file("j2.json", j);
  CHECK(error_of([&] { read_interhand_joints(p, 0); }) ==
        p + ": 0.7.world_coord[4]: expected array of 3, got array of 2");

  j = valid_joints();
  j["0"]["7"].erase("joint_valid");
  p = file("j3.json", j);
  CHECK(error_of([&] { read_interhand_joints(p, 0); }) == p + ": 0.7: missing key \"joint_valid\"");

  j = valid_joints();
  j["0"]["seven"] = j["0"]["7"];
  p = file("j4.json", j);
  CHECK(error_of([&] { read_interhand_joints(p, 0); }) ==
        p + ": 0.seven: frame key is not an integer");

  p = file("j5.json", json{{"0", json::array()}});
  CHECK(error_of([&] { read_interhand_joints(p, 0); }) ==
        p + ": 0: expected object, got array of 0");
}

TEST_CASE("annotation errors: MANO_NeuralAnnot.json wrong shapes and keys") {
  json m = valid_mano();
  m["0"]["7"]["right"]["pose"] = std::vector<double>(45, 0.0);
  std::string p = file("m1.json", m);
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) ==
        p + ": 0.7.right.pose: expected array of 48, got array of 45");

  m = valid_mano();
  m["0"]["7"]["right"].erase("shape");
  p = file("m2.json", m);
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) == p + ": 0.7.right: missing key \"shape\"");

  m = valid_mano();
  m["0"]["7"]["right"]["trans"] = "origin";
  p = file("m3.json", m);
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) ==
        p + ": 0.7.right.trans: expected array of 3, got string");

  m = valid_mano();
  m["0"]["7"]["left"] = 5;
  p = file("m4.json", m);
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) ==
        p + ": 0.7.left: expected object, got number");

  // Implausible values name the file, frame, hand and value (shape 1e6 gave empty masks).
  m = valid_mano();
  m["0"]["7"]["right"]["shape"][3] = 1e6;
  p = file("m6.json", m);
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) ==
        p + ": 0.7.right: shape[3] = 1e+06 is beyond +-10 standard deviations: not a hand");
  m = valid_mano();
  m["0"]["7"]["right"]["pose"][4] = 7.0;  // joint 1: |(0.1, 7, 0.1)| > 2 pi
  p = file("m7.json", m);
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) ==
        p + ": 0.7.right: pose[3..5] rotates joint 1 by 7.00143 rad, more than 2 pi");
  m = valid_mano();
  m["0"]["7"]["right"]["trans"][2] = 1e30;
  p = file("m8.json", m);
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) ==
        p + ": 0.7.right: trans[2] = 1e+30 m is more than 10 m from the capture's origin");
  // The bounds themselves are plausible: 9.9 standard deviations, an angle of 6.2 rad, 9.9 m.
  ManoParams edge;
  edge.shape.fill(9.9);
  edge.pose.fill(0);
  edge.pose[0] = 6.2;
  edge.trans = {9.9, -9.9, 0};
  CHECK(mano_problem(edge).empty());

  // Null frames and null hands are data, not errors.
  m = valid_mano();
  m["0"]["8"] = nullptr;
  m["0"]["9"] = {{"right", nullptr}, {"left", nullptr}};
  p = file("m5.json", m);
  const auto frames = read_interhand_mano(p, 0);
  CHECK(frames.size() == 3);
  CHECK_FALSE(frames.at(8).right.has_value());
  CHECK_FALSE(frames.at(9).right.has_value());
}

TEST_CASE("annotation errors: streaming keeps only the selected capture") {
  json j = valid_joints();
  j["1"] = {{"3", "not even a frame"}};  // malformed entries of other captures are never read
  const std::string p = file("stream.json", j);
  const auto frames = read_interhand_joints(p, 0);
  CHECK(frames.size() == 1);
  CHECK(error_of([&] { read_interhand_joints(p, 1); }) == p + ": 1.3: expected object, got string");
}

TEST_CASE("annotation errors: a key given twice in a streamed file names its path") {
  // nlohmann keeps the last of two equal keys; the streamed readers refuse them.
  const std::string twice = ": key given twice (remove one; JSON readers would keep the last)";
  auto raw = [](const std::string& name, const std::string& text) {
    static const std::string dir = data_test::fresh_dir("duplicate_keys");
    return data_test::write_text(dir + "/" + name, text);
  };
  const json hand = valid_mano()["0"]["7"]["right"];
  const json frame = valid_mano()["0"]["7"];
  std::string p = raw("frame_twice.json", "{\"0\": {\"7\": " + frame.dump() + ", \"7\": " + frame.dump() + "}}");
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) == p + ": 0.7" + twice);

  p = raw("field_twice.json", "{\"0\": {\"7\": {\"right\": {\"pose\": " + hand["pose"].dump() +
                                  ", \"shape\": " + hand["shape"].dump() + ", \"trans\": " +
                                  hand["trans"].dump() + ", \"pose\": " + hand["pose"].dump() +
                                  "}, \"left\": null}}}");
  CHECK(error_of([&] { read_interhand_mano(p, 0); }) == p + ": 0.7.right.pose" + twice);

  const json cameras = valid_cameras()["0"];
  p = raw("capture_twice.json", "{\"0\": " + cameras.dump() + ", \"0\": " + cameras.dump() + "}");
  CHECK(error_of([&] { read_interhand_cameras(p, 0); }) == p + ": 0" + twice);

  std::string data = valid_data().dump();
  const std::string id = "\"id\":5,";
  const size_t at = data.find(id, data.find("\"images\""));
  REQUIRE(at != std::string::npos);
  data.replace(at, id.size(), id + id);  // the first image's id twice
  p = raw("image_key_twice.json", data);
  CHECK(error_of([&] { read_interhand_images(p, ImageFilter{}); }) == p + ": images[0].id" + twice);

  // Keys of captures that are not read are not checked (they are skipped unparsed).
  p = raw("other_capture_twice.json", "{\"0\": {\"7\": " + frame.dump() + "}, \"1\": {\"3\": " +
                                          frame.dump() + ", \"3\": " + frame.dump() + "}}");
  CHECK(read_interhand_mano(p, 0).size() == 1);
}
