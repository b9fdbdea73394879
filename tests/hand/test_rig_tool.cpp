// handscs-rig's actions (run_rig_tool) and the rig summary: writing the built-in hand as a rig
// file, describing it, exporting OBJ, and the errors for meaningless option sets.
#include <ATen/ATen.h>

#include <filesystem>
#include <sstream>

#include "core/atomic_file.h"
#include "hand/rig.h"
#include "hand/rig_info.h"
#include "hand/rig_tool.h"

#include "catch_after_torch.h"  // last: after c10's glog (see there)

using namespace handscs;

TEST_CASE("handscs-rig: --builtin --left --out writes a loadable left-hand rig, --obj exports it") {
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("handscs_rig_tool_" + std::to_string(::getpid())))
          .string();
  std::filesystem::create_directories(dir);
  RigToolOptions options;
  options.builtin = true;
  options.left = true;
  options.out = dir + "/left.json";
  options.obj = dir + "/left.obj";
  run_rig_tool(options);
  const Rig rig = load_rig(dir + "/left.json");
  CHECK(rig.handedness == Handedness::left);
  CHECK(rig.name == "builtin");
  const std::string obj = read_file(dir + "/left.obj");
  size_t vertices = 0, faces = 0;
  std::istringstream lines(obj);
  for (std::string line; std::getline(lines, line);) {
    vertices += line.rfind("v ", 0) == 0;
    faces += line.rfind("f ", 0) == 0;
  }
  CHECK(static_cast<int64_t>(vertices) == rig.num_vertices());
  CHECK(static_cast<int64_t>(faces) == rig.faces.size(0));
  std::filesystem::remove_all(dir);
}

TEST_CASE("handscs-rig: --info summary names counts, handedness, size and joints") {
  const Rig rig = load_rig_source("builtin:left");
  const std::string text = describe_rig(rig);
  CHECK_THAT(text, Catch::Contains("handedness: left"));
  CHECK_THAT(text, Catch::Contains("vertices: " + std::to_string(rig.num_vertices()) + "\n"));
  CHECK_THAT(text, Catch::Contains("faces: " + std::to_string(rig.faces.size(0)) + "\n"));
  CHECK_THAT(text, Catch::Contains("joints: 16 (+5 tips = 21)"));
  CHECK_THAT(text, Catch::Contains("wrist to middle tip (m): 0.18"));
  CHECK_THAT(text, Catch::Contains("20 pinky_tip: "));
  CHECK_THAT(text, Catch::Contains("bounding box min (m): -0.1270"));  // the mirrored forearm stub
}

TEST_CASE("handscs-rig: meaningless option sets are errors") {
  CHECK_THROWS_WITH(
      run_rig_tool(RigToolOptions{}),
      "handscs-rig: nothing to do (use --builtin [--left] --out FILE, or --info RIG)");
  RigToolOptions left_only;
  left_only.left = true;
  left_only.info = "builtin";
  CHECK_THROWS_WITH(run_rig_tool(left_only), "handscs-rig: --left needs --builtin");
  RigToolOptions out_only;
  out_only.info = "builtin";
  out_only.out = "/tmp/x.json";
  CHECK_THROWS_WITH(run_rig_tool(out_only), "handscs-rig: --out needs --builtin");
}
