// Config loading: defaults, files with "extends", --set overrides, and the error for each bad input.
#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/config.h"
#include "test_support.h"

namespace {

struct LrConfig {
  double means = 1.6e-4;
  double colors = 2.5e-3;
  template <class V>
  void visit(V& v) {
    v.field("means", means, "learning rate of the means", 0.0, 1.0);
    v.field("colors", colors, "learning rate of the colours", 0.0, 1.0);
  }
};

struct TrainConfig {
  int iterations = 100;
  std::string split = "novel_pose";
  std::vector<int> cameras = {1, 2};
  std::vector<std::array<int, 2>> edges = {{0, 1}};
  bool lpips = true;
  LrConfig lr;
  template <class V>
  void visit(V& v) {
    v.field("iterations", iterations, "training steps", 1, 1e7);
    v.choice("split", split, {"novel_pose", "novel_view"}, "which split rule");
    v.field("cameras", cameras, "camera ids");
    v.field("edges", edges, "bone edges");
    v.field("lpips", lpips, "LPIPS loss on");
    v.section("lr", lr, "learning rates");
  }
};

struct RootConfig {
  TrainConfig train;
  template <class V>
  void visit(V& v) {
    v.section("train", train, "training");
  }
};

std::string temp_file(const std::string& name, const std::string& text) {
  return handscs_test::scratch_file("handscs_test_config", name, text);
}

using handscs_test::error_of;

}  // namespace

TEST_CASE("config: defaults round-trip through JSON") {
  RootConfig config;
  const auto j = handscs::config_to_json(config);
  CHECK(j["train"]["iterations"] == 100);
  CHECK(j["train"]["lr"]["means"] == Approx(1.6e-4));
  RootConfig back;
  back.train.iterations = 7;
  handscs::config_from_json(j, "mem", back);
  CHECK(back.train.iterations == 100);
  CHECK(back.train.edges == config.train.edges);
}

TEST_CASE("config: file values, extends and --set overrides apply in order") {
  const auto base = temp_file("base.json", R"({"train": {"iterations": 50, "lr": {"means": 0.01}}})");
  const auto child =
      temp_file("child.json", R"({"extends": "base.json", "train": {"split": "novel_view"}})");
  auto config = handscs::load_config<RootConfig>(
      child, {"train.lr.colors=0.5", "train.cameras=[4,5,6]", "train.lpips=false"});
  CHECK(config.train.iterations == 50);
  CHECK(config.train.split == "novel_view");
  CHECK(config.train.lr.means == Approx(0.01));
  CHECK(config.train.lr.colors == Approx(0.5));
  CHECK(config.train.cameras == std::vector<int>{4, 5, 6});
  CHECK_FALSE(config.train.lpips);
  (void)base;
}

TEST_CASE("config: each bad input names the file and key") {
  const auto wrong_type = temp_file("x.json", R"({"train": {"lr": {"means": "fast"}}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(wrong_type, {}); }) ==
        wrong_type + ": train.lr.means: expected number, got string");

  const auto unknown = temp_file("unknown.json", R"({"train": {"iteratons": 5}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(unknown, {}); }) ==
        unknown + ": train.iteratons: unknown key");

  const auto range = temp_file("range.json", R"({"train": {"lr": {"means": 3}}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(range, {}); }) ==
        range + ": train.lr.means: value 3 out of range [0, 1]");

  const auto choice = temp_file("choice.json", R"({"train": {"split": "sideways"}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(choice, {}); }) ==
        choice + ": train.split: unknown value \"sideways\" (known: novel_pose, novel_view)");

  const auto fraction = temp_file("fraction.json", R"({"train": {"iterations": 2.5}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(fraction, {}); }) ==
        fraction + ": train.iterations: expected integer, got 2.5");

  const auto element = temp_file("element.json", R"({"train": {"cameras": [1, "b"]}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(element, {}); }) ==
        element + ": train.cameras[1]: expected integer, got string");

  const auto missing = std::string("/nonexistent/handscs.json");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(missing, {}); }) ==
        missing + ": cannot open file");

  const auto malformed = temp_file("malformed.json", "{\n  \"train\": {\n    \"iterations\": 5,\n  }\n}");
  const auto message = error_of([&] { handscs::load_config<RootConfig>(malformed, {}); });
  CHECK(message.rfind(malformed + ": malformed JSON at line 4, column 3", 0) == 0);

  const auto overflow = temp_file("overflow.json", R"({"train": {"iterations": 1e999}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(overflow, {}); })
            .rfind(overflow + ": a number is out of range of a double (", 0) == 0);
  const auto folder = std::filesystem::path(overflow).parent_path().string();
  CHECK(error_of([&] { handscs::load_config<RootConfig>(folder, {}); }) ==
        folder + ": is a folder, not a JSON file");
  // A key given twice (nlohmann would keep the last silently), at the top and nested under arrays.
  const auto twice = temp_file("twice.json", R"({"train": {"iterations": 400, "seed": 1, "iterations": 4}})");
  CHECK(error_of([&] { handscs::load_config<RootConfig>(twice, {}); }) ==
        twice + ": train.iterations: key given twice (remove one; JSON readers would keep the last)");
  const auto nested = temp_file("nested.json", R"({"poses": [{"pose": 1}, {"trans": 2, "trans": 3}]})");
  CHECK(error_of([&] { handscs::parse_json_file(nested); }) ==
        nested + ": poses[].trans: key given twice (remove one; JSON readers would keep the last)");
  CHECK(handscs::parse_json_file(temp_file("same_names.json", R"({"a": {"x": 1}, "b": {"x": 2}})"))["b"]["x"] == 2);
  // A device that never ends: refused before it is opened, not read until memory runs out.
  CHECK(error_of([&] { handscs::load_config<RootConfig>("/dev/zero", {}); }) ==
        "/dev/zero: is not a regular file (a named pipe, a device or a socket); give a file");

  CHECK(error_of([&] { handscs::load_config<RootConfig>("", {"train.lr.mean=1"}); }) ==
        "--set train.lr.mean=1: unknown key train.lr.mean");
  CHECK(error_of([&] { handscs::load_config<RootConfig>("", {"train.iterations=abc"}); }) ==
        "defaults + --set: train.iterations: expected integer, got string");
  CHECK(error_of([&] { handscs::load_config<RootConfig>("", {"novalue"}); }) ==
        "--set novalue: expected key.path=value");
  // A number beyond a double is named with its --set, not as the parser's raw exception.
  CHECK(error_of([&] { handscs::load_config<RootConfig>("", {"train.iterations=1e999"}); }) ==
        "--set train.iterations=1e999: 1e999 is beyond the range of a number (about 1.8e308)");
  // A section given a value is blamed itself, not the valid --set after it.
  const auto section_error = error_of([&] { handscs::load_config<RootConfig>("", {"train=5", "train.iterations=3"}); });
  CHECK(section_error.rfind("--set train=5: train is a section, not a value; set its keys, e.g. train.", 0) == 0);
}

TEST_CASE("config: markdown documentation lists every key") {
  RootConfig config;
  const auto doc = handscs::config_markdown(config);
  for (const char* key : {"train.iterations", "train.split", "train.cameras", "train.edges",
                          "train.lpips", "train.lr.means", "train.lr.colors"})
    CHECK(doc.find(std::string("`") + key + "`") != std::string::npos);
}

namespace {
struct EnumChoiceConfig {
  enum class Colour { red, green };
  Colour colour = Colour::green;
  template <class V>
  void visit(V& v) {
    v.choice("colour", colour, {{"red", Colour::red}, {"green", Colour::green}}, "a colour");
  }
};
}  // namespace

TEST_CASE("config: an enum choice reads, writes and documents its names") {
  EnumChoiceConfig config;
  CHECK(handscs::config_to_json(config) == handscs::json{{"colour", "green"}});
  handscs::config_from_json(handscs::json{{"colour", "red"}}, "file.json", config);
  CHECK(config.colour == EnumChoiceConfig::Colour::red);
  CHECK(handscs::config_to_json(config) == handscs::json{{"colour", "red"}});
  CHECK(handscs_test::error_of([&] {
          handscs::config_from_json(handscs::json{{"colour", "blue"}}, "file.json", config);
        }) == "file.json: colour: unknown value \"blue\" (known: red, green)");
  CHECK(config.colour == EnumChoiceConfig::Colour::red);  // unchanged by the refused value
  EnumChoiceConfig defaults;
  CHECK(handscs::config_markdown(defaults).find("| `colour` |") != std::string::npos);
  CHECK(handscs::config_markdown(defaults).find("red, green") != std::string::npos);
}
