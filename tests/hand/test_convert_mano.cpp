// scripts/convert_mano.py: fake Python-2 MANO pickles (tests/hand/fake_mano.py: the released files'
// structure, shapedirs a chumpy Select, J_regressor a scipy csc_matrix, latin1 strings) are
// converted, loaded as rigs, and their C++ LBS is compared with a numpy reference computed from the
// pickles' own arrays. Needs python3 with numpy (scripts/install-deps.sh).
#include <ATen/ATen.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>
#include <vector>

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

// A fresh folder <temp>/handscs_<tag>_<pid> holding tests/hand/fake_mano.py's pickles.
std::string fake_mano_dir(const std::string& python, const std::string& tag) {
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("handscs_" + tag + "_" + std::to_string(::getpid())))
                              .string();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const Run fake = run(python + " '" + HANDSCS_SOURCE_DIR + "/tests/hand/fake_mano.py' '" + dir +
                           "'",
                       dir);
  INFO(fake.output);
  REQUIRE(fake.status == 0);
  return dir;
}

// Names in `dir` that hold ".tmp." (a writer's temporary left behind).
std::vector<std::string> temporaries(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.find(".tmp.") != std::string::npos) names.push_back(name);
  }
  return names;
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
  const std::string dir = fake_mano_dir(python, "mano_test");
  const std::string script = std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_mano.py";
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
  const std::string dir = fake_mano_dir(python, "mano_bad");
  const std::string script =
      python + " '" + std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_mano.py' ";

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

TEST_CASE("convert_mano.py: never overwrites its input or an existing file, and a failed write "
          "leaves no temporary") {
  const std::string python = python_with_numpy();
  REQUIRE_FALSE(python.empty());
  const std::string dir = fake_mano_dir(python, "mano_output");
  const std::string script =
      python + " '" + std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_mano.py' ";
  const std::string pickle = dir + "/MANO_RIGHT.pkl";
  const std::string tips = " --tips 3,11,19,27,35";
  const std::string pickle_bytes = read_file(pickle);

  // The pickle named as the output: by its own name, through a symlink and through a hard link;
  // --force does not change that.
  std::filesystem::create_symlink(pickle, dir + "/link.json");
  std::filesystem::create_hard_link(pickle, dir + "/hard.json");
  for (const std::string& output : {pickle, dir + "/link.json", dir + "/hard.json"}) {
    const Run r = run(script + "'" + pickle + "' '" + output + "' --force" + tips, dir);
    CHECK(WEXITSTATUS(r.status) == 1);
    CHECK(r.output == "convert_mano.py: " + output + ": is the input pickle " + pickle +
                          "; name another output file\n");
  }
  CHECK(read_file(pickle) == pickle_bytes);

  std::filesystem::create_directories(dir + "/folder");
  Run r = run(script + "'" + pickle + "' '" + dir + "/folder' --force" + tips, dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir + "/folder: is a folder; name a rig file to write\n");

  std::ofstream(dir + "/old.json") << "mine";
  r = run(script + "'" + pickle + "' '" + dir + "/old.json'" + tips, dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir + "/old.json: exists; pass --force to replace it\n");
  CHECK(read_file(dir + "/old.json") == "mine");
  // A missing pickle is named as such, not as an output that exists.
  r = run(script + "'" + dir + "/missing_right.pkl' '" + dir + "/old.json'" + tips, dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/missing_right.pkl: cannot read: No such file or directory\n");
  r = run(script + "'" + pickle + "' '" + dir + "/old.json' --force" + tips, dir);
  CHECK(r.status == 0);
  CHECK(load_rig(dir + "/old.json").name == "MANO_RIGHT");

  // A full disk: a file size limit of 64 blocks (at most 64 KiB) stops the ~0.4 MB rig mid-write.
  r = run("(ulimit -f 64; " + script + "'" + pickle + "' '" + dir + "/full.json'" + tips + ")",
          dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir + "/full.json: cannot write (File too large)\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/full.json"));

  // The rename failing (the script run with os.replace raising ENOSPC).
  std::ofstream(dir + "/failing_replace.py")
      << "import errno, os, runpy, sys\n"
         "def no_space(*args):\n"
         "    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))\n"
         "os.replace = no_space\n"
         "sys.argv = sys.argv[1:]\n"
         "runpy.run_path(sys.argv[0], run_name='__main__')\n";
  r = run(python + " '" + dir + "/failing_replace.py' '" + std::string(HANDSCS_SOURCE_DIR) +
              "/scripts/convert_mano.py' '" + pickle + "' '" + dir + "/renamed.json'" + tips,
          dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output ==
        "convert_mano.py: " + dir + "/renamed.json: cannot write (No space left on device)\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/renamed.json"));

  CHECK(temporaries(dir).empty());
  CHECK(read_file(pickle) == pickle_bytes);
  std::filesystem::remove_all(dir);
}

TEST_CASE("convert_mano.py: a plain numpy MANO pickled by Python 3 with protocol 2 converts as the "
          "released file does") {
  const std::string python = python_with_numpy();
  REQUIRE_FALSE(python.empty());
  const std::string dir = fake_mano_dir(python, "mano_plain");
  const std::string script =
      python + " '" + std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_mano.py' ";
  const std::string tips = " --tips 3,11,19,27,35";

  // Its array bytes are _codecs.encode(text, 'latin1') calls (the converter once stubbed them:
  // "not a MANO pickle (TypeError: Cannot interpret '<__main__._Inert object ...>' as a data
  // type)").
  Run r = run(script + "'" + dir + "/plain_right.pkl' '" + dir + "/plain.json'" + tips, dir);
  INFO(r.output);
  REQUIRE(r.status == 0);
  REQUIRE(run(script + "'" + dir + "/MANO_RIGHT.pkl' '" + dir + "/released.json'" + tips, dir)
              .status == 0);
  const Rig plain = load_rig(dir + "/plain.json");
  const Rig released = load_rig(dir + "/released.json");
  CHECK(plain.handedness == released.handedness);
  CHECK(torch::equal(plain.v_template, released.v_template));
  CHECK(torch::equal(plain.faces, released.faces));
  CHECK(torch::equal(plain.weights, released.weights));
  CHECK(torch::equal(plain.j_regressor, released.j_regressor));
  CHECK(torch::equal(plain.posedirs, released.posedirs));
  CHECK(torch::equal(plain.shapedirs, released.shapedirs));
  CHECK(torch::equal(plain.hands_mean, released.hands_mean));

  // Only latin1 text to bytes is answered.
  r = run(script + "'" + dir + "/codecs_right.pkl' '" + dir + "/codecs.json'" + tips, dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/codecs_right.pkl: the pickle calls _codecs.encode with a str and "
                        "'utf-16': only latin1 text to bytes is supported\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/codecs.json"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("convert_mano.py: a damaged sparse J_regressor is named before anything is allocated") {
  const std::string python = python_with_numpy();
  REQUIRE_FALSE(python.empty());
  const std::string dir = fake_mano_dir(python, "mano_sparse");
  const std::string script =
      python + " '" + std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_mano.py' ";
  // Each once ended in a traceback: numpy's "Unable to allocate 7.28 TiB" (huge), an IndexError
  // (index), "negative dimensions are not allowed" (negative); big allocated 12.8 GB of zeros
  // before its pointers were found short.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"huge", "J_regressor: expected shape [16, 40], got [1000000, 1000000]"},
      {"big", "J_regressor: expected shape [16, 40], got [40000, 40000]"},
      {"negative", "J_regressor: csc matrix of negative shape [-16, 40]"},
      {"fractional", "J_regressor: csc matrix without a _shape of two integers"},
      {"index", "J_regressor: csc matrix row index 1000000000 out of range [0, 16)"},
      {"pointers", "J_regressor: csc matrix indptr does not rise from 0 to its 40 values"},
      {"nested", "shapedirs.a: csc matrix of shape [100000, 1000]: more values than any MANO "
                 "array (at most 10000000)"},
  };
  for (const auto& [name, message] : cases) {
    const std::string pickle = dir + "/sparse_" + name + "_right.pkl";
    // 8 GB of address space: far more than python and numpy start with, less than big's 12.8 GB,
    // so an allocation before the checks fails here even where memory is overcommitted.
    const Run r = run("(ulimit -v 8000000; " + script + "'" + pickle + "' '" + dir +
                          "/out.json' --tips 3,11,19,27,35)",
                      dir);
    INFO(name);
    CHECK(WEXITSTATUS(r.status) == 1);
    CHECK(r.output == "convert_mano.py: " + pickle + ": " + message + "\n");
  }
  CHECK_FALSE(std::filesystem::exists(dir + "/out.json"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("convert_mano.py: a hand label the geometry contradicts is refused") {
  const std::string python = python_with_numpy();
  REQUIRE_FALSE(python.empty());
  const std::string dir = fake_mano_dir(python, "mano_hand");
  const std::string script =
      python + " '" + std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_mano.py' ";
  const std::string tips = " --tips 3,11,19,27,35";
  const std::string left_geometry =
      "the geometry is a left hand: its fingers (wrist to middle knuckle) x knuckle line (pinky to "
      "index) point to -y, a left hand's palm in MANO's frame; use --hand left\n";

  // Once written as a right rig holding the left hand's geometry (rc 0).
  Run r = run(script + "'" + dir + "/MANO_LEFT.pkl' '" + dir + "/out.json' --hand right" + tips,
              dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output ==
        "convert_mano.py: " + dir + "/MANO_LEFT.pkl: --hand right, but " + left_geometry);

  std::filesystem::copy_file(dir + "/MANO_LEFT.pkl", dir + "/copy_RIGHT.pkl");
  r = run(script + "'" + dir + "/copy_RIGHT.pkl' '" + dir + "/out.json'" + tips, dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir + "/copy_RIGHT.pkl: the file name says right, but " +
                        left_geometry);

  r = run(script + "'" + dir + "/MANO_RIGHT.pkl' '" + dir + "/out.json' --hand left" + tips, dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/MANO_RIGHT.pkl: --hand left, but the geometry is a right hand: its "
                        "fingers (wrist to middle knuckle) x knuckle line (pinky to index) point "
                        "to +y, a right hand's back in MANO's frame; use --hand right\n");

  // A hand whose back faces +z is no hand in MANO's frame: neither label can be checked.
  r = run(script + "'" + dir + "/turned_right.pkl' '" + dir + "/out.json'" + tips, dir);
  CHECK(WEXITSTATUS(r.status) == 1);
  CHECK(r.output == "convert_mano.py: " + dir +
                        "/turned_right.pkl: the rest joints form no hand in MANO's frame (their "
                        "fingers x knuckle line is at cosine 0.14 to y; a hand's is at least 0.5 "
                        "either way): cannot tell which hand it is\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/out.json"));

  r = run(script + "'" + dir + "/copy_RIGHT.pkl' '" + dir + "/out.json' --hand left" + tips, dir);
  INFO(r.output);
  CHECK(r.status == 0);
  CHECK(load_rig(dir + "/out.json").handedness == Handedness::left);
  std::filesystem::remove_all(dir);
}

TEST_CASE("convert_mano.py: hostile pickles are refused by name: foreign globals, deep or huge lists, "
          "a named pipe") {
  const std::string python = python_with_numpy();
  REQUIRE_FALSE(python.empty());
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("handscs_mano_hostile_" + std::to_string(::getpid())))
                              .string();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // Globals off the allow list (each would run `touch pwned` if called), a list nested 200,000
  // deep, and a 2 MB pickle that references one 1,000-number row a million times (8 GB as an array).
  const std::string writer = R"(
import pickle, sys
d = sys.argv[1]
def call(module, name):
    return b"c" + module.encode() + b"\n" + name.encode() + b"\n(S'" + d.encode() + b"/pwned'\ntR."
for module, name in [("nt", "system"), ("io", "open"), ("shutil", "copy"),
                     ("importlib", "import_module"), ("operator", "attrgetter")]:
    open(f"{d}/{module}.{name}_right.pkl", "wb").write(call(module, name))
n = 200000
open(f"{d}/deep_right.pkl", "wb").write(b"\x80\x02}U\x0av_template" + b"]" * n + b"a" * (n - 1) + b"s.")
open(f"{d}/wide_right.pkl", "wb").write(pickle.dumps({"v_template": [[0.5] * 1000] * 10**6}, protocol=2))
)";
  write_file_atomic(dir + "/write.py", writer);
  REQUIRE(run(python + " '" + dir + "/write.py' '" + dir + "'", dir).status == 0);
  const std::string script =
      python + " '" + std::string(HANDSCS_SOURCE_DIR) + "/scripts/convert_mano.py' ";
  const auto refusal = [&](const std::string& name) {
    const Run r = run(script + "'" + dir + "/" + name + "' '" + dir + "/out.json'", dir);
    CHECK(r.status != 0);
    return r.output;
  };
  for (const std::string global :
       {"nt.system", "io.open", "shutil.copy", "importlib.import_module", "operator.attrgetter"})
    CHECK(refusal(global + "_right.pkl") ==
          "convert_mano.py: " + dir + "/" + global + "_right.pkl: the pickle asks for " + global +
              ", which a MANO file does not need: refusing to load it\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/pwned"));
  CHECK(refusal("deep_right.pkl") == "convert_mano.py: " + dir +
                                         "/deep_right.pkl: v_template: lists nested deeper than 8 "
                                         "levels: not a MANO array\n");
  CHECK(refusal("wide_right.pkl") == "convert_mano.py: " + dir +
                                         "/wide_right.pkl: v_template: lists of more than "
                                         "10,000,000 numbers: not a MANO array\n");
  REQUIRE(::mkfifo((dir + "/pipe_right.pkl").c_str(), 0600) == 0);
  CHECK(refusal("pipe_right.pkl") == "convert_mano.py: " + dir +
                                         "/pipe_right.pkl: is not a regular file (a named pipe, a "
                                         "device or a socket); give a file\n");
  CHECK_FALSE(std::filesystem::exists(dir + "/out.json"));
  std::filesystem::remove_all(dir);
}
