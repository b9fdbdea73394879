// Request bodies of the render, camera and save endpoints (view/view_request.h): one pose source,
// bounds from the POSES reader (MANO plausibility) and the view, errors that name the key.
#include "catch_torch.h"

#include <string>

#include "core/error.h"
#include "pose_text.h"
#include "test_support.h"
#include "view/view_request.h"

namespace {

std::string parse_error(const std::string& body) {
  return handscs_test::error_of([&] { handscs::parse_view_request(body, handscs::OrbitView{}); });
}

}  // namespace

TEST_CASE("view request: sources, format and defaults") {
  const handscs::OrbitView defaults;
  auto r = handscs::parse_view_request("{}", defaults);
  CHECK(r.source == handscs::ViewRequest::Source::controls);
  CHECK(r.format == handscs::ImageFormat::jpeg);
  CHECK(r.view.distance == defaults.distance);
  r = handscs::parse_view_request(R"({"held_out": 2, "format": "png", "view": {"yaw": 1}})", defaults);
  CHECK(r.source == handscs::ViewRequest::Source::held_out);
  CHECK(r.held_out == 2);
  CHECK(r.format == handscs::ImageFormat::png);
  CHECK(r.view.yaw == 1);
  r = handscs::parse_view_request("{\"pose\": {\"pose\": " + handscs_test::pose_text({"0", "0", "0", "0.5"}) + "}}", defaults);
  CHECK(r.source == handscs::ViewRequest::Source::pose);
  CHECK(r.pose.pose[3] == 0.5f);
}

TEST_CASE("view request: malformed and out-of-bounds bodies are errors naming the key") {
  CHECK(parse_error("{") == "request: not valid JSON");
  CHECK(parse_error("[1]") == "request: expected a JSON object, got array");
  CHECK(parse_error(R"({"held_out": 1, "controls": {}})") ==
        "request: give one of controls, held_out and pose, not 2");
  CHECK(parse_error(R"({"held_out": "1"})") == "request.held_out: expected an integer, got string");
  CHECK(parse_error(R"({"format": "gif"})") == "request.format: expected \"jpeg\" or \"png\", got \"gif\"");
  CHECK(parse_error(R"({"quality": 5})") == "request.quality: 5 is outside 50..100");
  CHECK(parse_error(R"({"path": "/etc/passwd"})") ==
        "request.path: unknown key (controls, held_out, pose, view, format, quality)");
  CHECK(parse_error(R"({"view": {"width": 4096}})") == "request.view.width: 4096 px is outside 32..2048");
  CHECK(parse_error(R"({"controls": {"index.mcp": 2}})") == "request.controls.index.mcp: 2.0 is outside -0.05..1.0");
  // The POSES reader's MANO bounds, with the request's key path.
  CHECK(parse_error("{\"pose\": {\"pose\": " + handscs_test::pose_text({"0", "0", "0", "30"}) + "}}") ==
        "request.pose: pose[3..5] rotates joint 1 by 30 rad, more than 2 pi");
  CHECK(parse_error("{\"pose\": {\"pose\": [1, 2]}}") == "request.pose.pose: expected 48 numbers, got 2 values");
  CHECK(parse_error(std::string(handscs::kMaxViewRequestBytes + 1, ' ')) ==
        "request: 16385 bytes, more than 16384");
}
