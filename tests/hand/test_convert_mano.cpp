// scripts/convert_mano.py: fake Python-2 MANO pickles (tests/hand/fake_mano.py: the released files'
// structure, shapedirs a chumpy Select, J_regressor a scipy csc_matrix, latin1 strings) are
// converted, loaded as rigs, and their C++ LBS is compared with a numpy reference computed from the
// pickles' own arrays. Needs python3 with numpy (scripts/install-deps.sh).
#include <ATen/ATen.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "hand/lbs.h"
#include "hand/rig.h"

#include "catch_after_torch.h"  // last: after c10's glog (see there)

using namespace handscs;
using json = nlohmann::json;

namespace {

// The first of python3 (PATH) and /usr/bin/python3 that imports numpy (a pyenv shim may lack it).
std::string python_with_numpy() {
  for (const char* candidate : {"python3", "/usr/bin/python3"}) {
    const std::string command = std::string(candidate) + " -c 'import numpy' > /dev/null 2>&1";
    if (std::system(command.c_str()) == 0) return candidate;
  }
  return "";
}

struct Run {
  int status;
  std::string output;  // stdout and stderr
};

Run run(const std::string& command, const std::string& dir) {
  const std::string log = dir + "/command.log";
  const int status = std::system((command + " > '" + log + "' 2>&1").c_str());
  return {status, read_file(log)};
}

torch::Tensor tensor_of(const json& value) {
  std::vector<double> flat;
  std::vector<int64_t> shape;
  const json* cursor = &value;
  while (cursor->is_array()) {
    shape.push_back(static_cast<int64_t>(cursor->size()));
    cursor = &(*cursor)[0];
  }
  std::function<void(const json&)> walk = [&](const json& v) {
    if (v.is_array())
      for (const json& item : v) walk(item);
    else
      flat.push_back(v.get<double>());
  };
  walk(value);
  return torch::tensor(flat, torch::kFloat64).reshape(shape);
}

}  // namespace

TEST_CASE(
    "convert_mano.py: fake MANO pickles convert to rigs whose LBS matches a numpy reference") {
  const std::string python = python_with_numpy();
  REQUIRE_FALSE(python.empty());  // install python3-numpy (scripts/install-deps.sh)
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("handscs_mano_test_" + std::to_string(::getpid())))
          .string();
  std::filesystem::create_directories(dir);
  const std::string source = HANDSCS_SOURCE_DIR;
  const std::string script = source + "/scripts/convert_mano.py";

  const Run fake = run(python + " '" + source + "/tests/hand/fake_mano.py' '" + dir + "'", dir);
  INFO(fake.output);
  REQUIRE(fake.status == 0);
  for (const std::string hand : {"RIGHT", "LEFT"}) {
    const Run convert = run(python + " '" + script + "' '" + dir + "/MANO_" + hand + ".pkl' '" +
                                dir + "/" + hand + ".json' --tips 3,11,19,27,35",
                            dir);
    INFO(convert.output);
    REQUIRE(convert.status == 0);
  }

  const Rig right = load_rig(dir + "/RIGHT.json");
  const Rig left = load_rig(dir + "/LEFT.json");
  CHECK(right.name == "MANO_RIGHT");
  CHECK(right.handedness == Handedness::right);
  CHECK(left.handedness == Handedness::left);
  CHECK(right.num_vertices() == 40);
  CHECK(right.faces.size(0) == 30);
  CHECK(right.tip_vertices == std::array<int64_t, 5>{3, 11, 19, 27, 35});
  CHECK(json::parse(read_file(dir + "/RIGHT.json"))["description"].get<std::string>().find(
            "do not commit") != std::string::npos);

  const json reference = json::parse(read_file(dir + "/reference.json"));
  int compared = 0;
  for (const json& c : reference["cases"]) {
    const Rig& rig = c["hand"] == "right" ? right : left;
    const torch::Tensor pose = tensor_of(c["pose"]).unsqueeze(0);
    const torch::Tensor shape = tensor_of(c["shape"]).unsqueeze(0);
    const torch::Tensor trans = tensor_of(c["trans"]).unsqueeze(0);
    const LbsOutput out = lbs(rig, pose, shape, trans, LbsOptions{c["flat_hand_mean"].get<bool>()});
    INFO("case " << compared << " (" << c["hand"] << ")");
    CHECK((out.vertices[0] - tensor_of(c["vertices"])).abs().max().item<double>() < 1e-12);
    CHECK((out.joints[0] - tensor_of(c["joints"])).abs().max().item<double>() < 1e-12);
    ++compared;
  }
  CHECK(compared == 12);
  std::filesystem::remove_all(dir);
}

TEST_CASE("convert_mano.py: bad input is reported with the file and the key, and writes nothing") {
  const std::string python = python_with_numpy();
  REQUIRE_FALSE(python.empty());
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("handscs_mano_bad_" + std::to_string(::getpid())))
          .string();
  std::filesystem::create_directories(dir);
  const std::string source = HANDSCS_SOURCE_DIR;
  const std::string script = python + " '" + source + "/scripts/convert_mano.py' ";
  REQUIRE(run(python + " '" + source + "/tests/hand/fake_mano.py' '" + dir + "'", dir).status == 0);

  Run r = run(script + "'" + dir + "/broken_right.pkl' '" + dir + "/out.json' --tips 3,11,19,27,35",
              dir);
  CHECK(r.status != 0);
  CHECK(r.output == "convert_mano.py: " + dir + "/broken_right.pkl: missing key 'J_regressor'\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/out.json"));

  // The released files' shapedirs is a chumpy Select; other chumpy expressions are named, not
  // guessed at (the converter once took the Select's only array, its indices).
  r = run(script + "'" + dir + "/unsupported_right.pkl' '" + dir +
              "/out.json' --tips 3,11,19,27,35",
          dir);
  CHECK(r.status != 0);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/unsupported_right.pkl: shapedirs: chumpy expression chumpy.ch_ops.add "
                        "is not supported (supported: Ch, Select, Reshape, Transpose); please "
                        "report it with the file's origin\n");

  r = run(script + "'" + dir + "/body_right.pkl' '" + dir + "/out.json' --tips 3,11,19,27,35", dir);
  CHECK(r.status != 0);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/body_right.pkl: kintree_table: 24 joints, MANO has 16 (SMPL has 24, "
                        "SMPL+H 52, SMPL-X 55): not a MANO hand model\n");

  r = run(script + "'" + dir + "/other_right.pkl' '" + dir + "/out.json'", dir);
  CHECK(r.status != 0);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/other_right.pkl: not a MANO pickle: none of the keys v_template, f, "
                        "weights, J_regressor, posedirs, shapedirs, hands_mean (it holds epoch, "
                        "weights_of_a_network)\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/out.json"));

  r = run(script + "'" + dir + "/MANO_RIGHT.pkl' '" + dir + "/out.json'", dir);
  CHECK(r.status != 0);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/MANO_RIGHT.pkl: 40 vertices (MANO has 778): pass the fingertip vertices "
                        "with --tips\n");

  std::ofstream(dir + "/hand.pkl") << "not a pickle";
  r = run(script + "'" + dir + "/hand.pkl' '" + dir + "/out.json' --hand right", dir);
  CHECK(r.status != 0);
  CHECK(r.output.find("hand.pkl: not a MANO pickle") != std::string::npos);

  r = run(script + "'" + dir + "/hand.pkl' '" + dir + "/out.json'", dir);
  CHECK(r.status != 0);
  CHECK(r.output.find("cannot tell the hand from the file name") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir + "/out.json"));
  std::filesystem::remove_all(dir);
}
