// Rig files: exact round trips (dense and sparse arrays), rig sources, and the error for each kind
// of bad file (message names the file and the key).
#include <ATen/ATen.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "hand/procedural_hand.h"
#include "hand/rig.h"
#include "rig_fixtures.h"

#include "catch_after_torch.h"  // last: after c10's glog (see there)

using namespace handscs;
using json = nlohmann::json;

namespace {

std::string temp_dir() {
  const auto dir =
      std::filesystem::temp_directory_path() / ("handscs_rig_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

void check_same(const Rig& a, const Rig& b) {
  CHECK(a.name == b.name);
  CHECK(a.handedness == b.handedness);
  CHECK(torch::equal(a.v_template, b.v_template));
  CHECK(torch::equal(a.faces, b.faces));
  CHECK(torch::equal(a.weights, b.weights));
  CHECK(torch::equal(a.j_regressor, b.j_regressor));
  CHECK(a.parents == b.parents);
  CHECK(torch::equal(a.posedirs, b.posedirs));
  CHECK(torch::equal(a.shapedirs, b.shapedirs));
  CHECK(torch::equal(a.hands_mean, b.hands_mean));
  CHECK(a.tip_vertices == b.tip_vertices);
  CHECK(a.vertex_labels.defined() == b.vertex_labels.defined());
  if (a.vertex_labels.defined()) CHECK(torch::equal(a.vertex_labels, b.vertex_labels));
  CHECK(a.v_template.scalar_type() == torch::kFloat64);
  CHECK(b.v_template.scalar_type() == torch::kFloat64);
}

// A valid toy rig file (dense arrays: V = 20) as JSON, to be broken by each test.
json toy_json(const std::string& dir) {
  const std::string path = dir + "/toy.json";
  save_rig(test::make_toy_rig(20, 1), path);
  return json::parse(read_file(path));
}

std::string write_json(const std::string& dir, const std::string& name, const json& value) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << value.dump();
  return path;
}

}  // namespace

TEST_CASE("rig file: the built-in hand round-trips exactly (sparse arrays)") {
  const std::string dir = temp_dir();
  for (Handedness hand : {Handedness::right, Handedness::left}) {
    const Rig rig = make_procedural_hand(hand);
    const std::string path = dir + "/builtin.json";
    save_rig(rig, path);
    const json file = json::parse(read_file(path));
    CHECK(file["j_regressor"].contains("sparse"));  // mostly zeros: written sparse
    CHECK(file["posedirs"].contains("sparse"));
    CHECK(file["format"] == "handscs-rig");
    check_same(rig, load_rig(path));
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("rig file: a rig with dense blend shapes round-trips exactly") {
  const std::string dir = temp_dir();
  const Rig rig = test::make_toy_rig(30, 4);
  const std::string path = dir + "/toy.json";
  save_rig(rig, path);
  CHECK(json::parse(read_file(path))["posedirs"].is_array());
  check_same(rig, load_rig(path));
  // No temporary file is left next to it (atomic write).
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    files += entry.is_regular_file();
  CHECK(files == 1);
  std::filesystem::remove_all(dir);
}

TEST_CASE("rig sources: builtin, builtin:left, files, and unknown built-ins") {
  const Rig right = load_rig_source("builtin");
  CHECK(right.handedness == Handedness::right);
  CHECK(load_rig_source("builtin:right").num_vertices() == right.num_vertices());
  const Rig left = load_rig_source("builtin:left");
  CHECK(left.handedness == Handedness::left);
  CHECK_THROWS_WITH(load_rig_source("builtin:foot"),
                    "rig source 'builtin:foot': unknown built-in rig (known: builtin, "
                    "builtin:right, builtin:left, builtin+fingers, builtin+fingers:left)");
  CHECK_THROWS_WITH(load_rig_source("/nonexistent/rig.json"),
                    "/nonexistent/rig.json: cannot open file");
}

TEST_CASE("rig file: each kind of bad file gives an error naming the file and the key") {
  const std::string dir = temp_dir();
  const json good = toy_json(dir);
  auto broken = [&](const std::function<void(json&)>& edit) {
    json value = good;
    edit(value);
    return write_json(dir, "bad.json", value);
  };
  std::string path;

  path = broken([](json& j) { j.erase("weights"); });
  CHECK_THROWS_WITH(load_rig(path), path + ": missing key 'weights'");

  path = broken([](json& j) { j["colour"] = "red"; });
  CHECK_THROWS_WITH(load_rig(path), path + ": unknown key 'colour'");

  path = broken([](json& j) { j["hands_mean"].erase(0); });
  CHECK_THROWS_WITH(load_rig(path), path + ": hands_mean: expected shape [45], got [44]");

  path = broken([](json& j) { j["v_template"][3].erase(2); });
  CHECK_THROWS_WITH(load_rig(path), path + ": v_template[3]: expected 3 entries, got 2");

  path = broken([](json& j) { j["weights"] = json::array({json::array({1.0})}); });
  CHECK_THROWS_WITH(load_rig(path), path + ": weights: expected shape [20, 16], got [1, 1]");

  path = broken([](json& j) { j["faces"][0][1] = "a"; });
  CHECK_THROWS_WITH(load_rig(path), path + ": faces[0][1]: expected number, got string");

  path = broken([](json& j) { j["faces"][0][1] = 1.5; });
  CHECK_THROWS_WITH(load_rig(path), path + ": faces[0][1]: expected integer, got 1.5");

  path =
      broken([](json& j) { j["v_template"][2][1] = nullptr; });  // how NaN is written by JSON libs
  CHECK_THROWS_WITH(load_rig(path), path + ": v_template[2][1]: expected number, got null");

  path = broken([](json& j) { j["weights"][4][0] = j["weights"][4][0].get<double>() + 0.5; });
  CHECK_THROWS_WITH(load_rig(path), Catch::StartsWith(path + ": weights[4]: row sums to 1.5") &&
                                        Catch::EndsWith(", expected 1"));

  path = broken([](json& j) { j["faces"][2][0] = 20; });
  CHECK_THROWS_WITH(load_rig(path), path + ": faces[2][0]: vertex index 20 out of range [0, 20)");

  path = broken([](json& j) { j["tip_vertices"][4] = 99; });
  CHECK_THROWS_WITH(load_rig(path),
                    path + ": tip_vertices[4]: vertex index 99 out of range [0, 20)");

  path = broken([](json& j) { j["parents"][2] = 0; });
  CHECK_THROWS_WITH(load_rig(path), path +
                                        ": parents: expected the MANO parents [-1, 0, 1, 2, 0, 4, "
                                        "5, 0, 7, 8, 0, 10, 11, 0, 13, 14], got [-1, 0, 0, 2, 0, "
                                        "4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14]");

  path = broken([](json& j) { j["handedness"] = "up"; });
  CHECK_THROWS_WITH(load_rig(path),
                    path + ": handedness: expected \"right\" or \"left\", got \"up\"");

  path = broken([](json& j) { j["format"] = "mano"; });
  CHECK_THROWS_WITH(load_rig(path), path + ": format: expected \"handscs-rig\", got \"mano\"");

  path = broken([](json& j) { j["version"] = 2; });
  CHECK_THROWS_WITH(load_rig(path), path + ": version: expected 1, got 2");

  path = broken([](json& j) {
    j["j_regressor"] = json{{"shape", {16, 20}}, {"sparse", {{16, 0, 0.5}}}};
  });
  CHECK_THROWS_WITH(load_rig(path),
                    path + ": j_regressor.sparse[0]: index 16 out of range [0, 16)");

  path = broken([](json& j) {
    j["j_regressor"] = json{{"shape", {16, 21}}, {"sparse", json::array()}};
  });
  CHECK_THROWS_WITH(load_rig(path), path + ": j_regressor: expected shape [16, 20], got [16, 21]");

  {
    const std::string text = good.dump();
    path = dir + "/truncated.json";
    std::ofstream(path) << text.substr(0, text.size() / 2);
    CHECK_THROWS_WITH(load_rig(path), Catch::StartsWith(path + ": malformed JSON at line 1, column "));
    path = dir + "/overflow.json";
    json value = good;
    value["v_template"][0][0] = 12345.0;
    std::string overflow = value.dump();
    overflow.replace(overflow.find("12345.0"), 7, "1e999");
    std::ofstream(path) << overflow;
    CHECK_THROWS_WITH(load_rig(path),
                      Catch::StartsWith(path + ": a number is out of range of a double") &&
                          Catch::Contains("1e999"));
    path = dir + "/array.json";
    std::ofstream(path) << "[1, 2]";
    CHECK_THROWS_WITH(load_rig(path), path + ": expected a JSON object at the top level");
  }
  CHECK_THROWS_WITH(load_rig(dir + "/missing.json"), dir + "/missing.json: cannot open file");
  std::filesystem::remove_all(dir);
}

TEST_CASE("rig file: save_rig refuses an inconsistent rig and leaves no file") {
  const std::string dir = temp_dir();
  Rig rig = test::make_toy_rig(10, 2);
  rig.v_template[1][2] = std::numeric_limits<double>::quiet_NaN();
  const std::string path = dir + "/nan.json";
  CHECK_THROWS_WITH(save_rig(rig, path), path + ": v_template[1][2]: non-finite value");
  CHECK_FALSE(std::filesystem::exists(path));
  rig = test::make_toy_rig(10, 2);
  rig.weights = rig.weights.slice(1, 0, 15);
  CHECK_THROWS_WITH(save_rig(rig, path), path + ": weights: expected shape [10, 16], got [10, 15]");
  rig = test::make_toy_rig(10, 2);
  rig.posedirs = torch::Tensor();
  CHECK_THROWS_WITH(save_rig(rig, path), path + ": posedirs: missing");
  std::filesystem::remove_all(dir);
}
