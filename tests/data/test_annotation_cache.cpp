// The annotation cache (data/annotation_cache.h): what it returns equals the streaming readers'
// result field for field; later opens read it (a change the key does not see goes unnoticed,
// as documented); a changed source rebuilds it; a damaged or foreign cache file is ignored and
// rebuilt; "off" writes nothing; an unwritable beside-data folder falls back to the user's cache.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/config.h"
#include "data/annotation_cache.h"
#include "data/capture_layout.h"
#include "synth_fixture.h"
#include "test_support.h"

using namespace data_test;
using handscs_test::ScopedEnv;
namespace fs = std::filesystem;

namespace {

void check_same_images(const std::vector<handscs::InterHandImage>& a,
                       const std::vector<handscs::InterHandImage>& b) {
  REQUIRE(a.size() == b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    INFO("image " << i);
    CHECK(a[i].id == b[i].id);
    CHECK(a[i].file_name == b[i].file_name);
    CHECK(a[i].width == b[i].width);
    CHECK(a[i].height == b[i].height);
    CHECK(a[i].capture == b[i].capture);
    CHECK(a[i].subject == b[i].subject);
    CHECK(a[i].seq_name == b[i].seq_name);
    CHECK(a[i].camera == b[i].camera);
    CHECK(a[i].frame_idx == b[i].frame_idx);
    CHECK(a[i].bbox == b[i].bbox);
    CHECK(a[i].joint_valid == b[i].joint_valid);
    CHECK(a[i].hand_type == b[i].hand_type);
    CHECK(a[i].hand_type_valid == b[i].hand_type_valid);
  }
}

void check_same_joints(const std::map<int64_t, handscs::InterHandJoints>& a,
                       const std::map<int64_t, handscs::InterHandJoints>& b) {
  REQUIRE(a.size() == b.size());
  for (const auto& [frame, joints] : a) {
    INFO("frame " << frame);
    REQUIRE(b.count(frame));
    CHECK(joints.world_mm == b.at(frame).world_mm);
    CHECK(joints.valid == b.at(frame).valid);
    CHECK(joints.hand_type == b.at(frame).hand_type);
    CHECK(joints.hand_type_valid == b.at(frame).hand_type_valid);
  }
}

void check_same_hand(const std::optional<handscs::ManoParams>& a,
                     const std::optional<handscs::ManoParams>& b) {
  REQUIRE(a.has_value() == b.has_value());
  if (!a) return;
  CHECK(a->pose == b->pose);
  CHECK(a->shape == b->shape);
  CHECK(a->trans == b->trans);
}

void check_same_mano(const std::map<int64_t, handscs::InterHandMano>& a,
                     const std::map<int64_t, handscs::InterHandMano>& b) {
  REQUIRE(a.size() == b.size());
  for (const auto& [frame, mano] : a) {
    INFO("frame " << frame);
    REQUIRE(b.count(frame));
    check_same_hand(mano.right, b.at(frame).right);
    check_same_hand(mano.left, b.at(frame).left);
  }
}

std::string cache_folder(const handscs::CaptureLayout& layout) {
  return (fs::path(layout.data_json).parent_path() / ".handscs-cache").string();
}

int files_in(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  int n = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++n;
  return n;
}

// A copy of the tiny capture without the annotation cache an earlier test may have left in it.
std::string fresh_copy(const std::string& name) {
  const std::string root = copy_of_tiny(name);
  fs::remove_all(cache_folder(handscs::resolve_capture_layout(root, "test")));
  return root;
}

}  // namespace

TEST_CASE("annotation cache: cached and uncached reads equal the streaming readers, field for field") {
  const std::string root = fresh_copy("cache_equal");
  const auto layout = handscs::resolve_capture_layout(root, "test");
  handscs::ImageFilter filter;
  filter.capture = 0;
  handscs::ImageCatalogue catalogue;
  const auto images = handscs::read_interhand_images(layout.data_json, filter, &catalogue);
  const auto joints = handscs::read_interhand_joints(layout.joint_3d_json, 0);
  const auto mano = handscs::read_interhand_mano(layout.mano_json, 0);
  REQUIRE(images.size() > 10);

  const handscs::AnnotationCache cache("auto");
  for (int pass = 0; pass < 2; ++pass) {  // pass 0 builds the cache, pass 1 reads it
    INFO("pass " << pass);
    const auto cached = cache.images(layout.data_json, 0);
    check_same_images(cached.images, images);
    CHECK(cached.catalogue.captures == catalogue.captures);
    CHECK(cached.catalogue.sequences == catalogue.sequences);
    check_same_joints(cache.joints(layout.joint_3d_json, 0), joints);
    check_same_mano(cache.mano(layout.mano_json, 0), mano);
    CHECK(files_in(cache_folder(layout)) == 3);
  }
  // A capture that is not in the file: empty, with the catalogue saying what is there.
  const auto absent = cache.images(layout.data_json, 7);
  CHECK(absent.images.empty());
  CHECK(absent.catalogue.captures == catalogue.captures);
}

TEST_CASE("annotation cache: a later open reads the cache, not the JSON") {
  const std::string root = fresh_copy("cache_used");
  const auto layout = handscs::resolve_capture_layout(root, "test");
  // 70 kB of JSON whitespace before and after the content put all of it outside the 64 KiB edges
  // the key hashes.
  const std::string padding(70 << 10, ' ');
  handscs::write_file_atomic(layout.data_json, padding + handscs::read_file(layout.data_json) + padding);
  const auto config = tiny_config(root);
  const auto first = handscs::Capture::open(config);
  REQUIRE(files_in(cache_folder(layout)) == 3);

  // Rename the sequence everywhere in data.json, keeping the size, the edges and the modification
  // time: the key cannot see it (documented), and the renamed file names point at no image, so an
  // open that parsed the JSON would find no usable image. The next open gives the cached frames.
  const std::string& name = first.frames().front().file_name;  // "Capture0/<seq>/cam.../image...jpg"
  const std::string seq = name.substr(name.find('/') + 1, name.find('/', name.find('/') + 1) - name.find('/') - 1);
  const auto time = fs::last_write_time(layout.data_json);
  std::string text = handscs::read_file(layout.data_json);
  const std::string renamed(seq.size(), 'x');
  for (size_t at = text.find(seq); at != std::string::npos; at = text.find(seq, at + 1))
    text.replace(at, seq.size(), renamed);
  handscs::write_file_atomic(layout.data_json, text);
  fs::last_write_time(layout.data_json, time);
  handscs::ImageFilter filter;
  filter.capture = 0;
  REQUIRE(handscs::read_interhand_images(layout.data_json, filter).front().seq_name == renamed);

  const auto second = handscs::Capture::open(config);
  REQUIRE(second.frames().size() == first.frames().size());
  for (size_t i = 0; i < first.frames().size(); ++i)
    CHECK(second.frames()[i].file_name == first.frames()[i].file_name);
}

TEST_CASE("annotation cache: a changed annotation file is read again") {
  const std::string root = fresh_copy("cache_changed");
  const auto layout = handscs::resolve_capture_layout(root, "test");
  const handscs::AnnotationCache cache("auto");
  const size_t before = cache.images(layout.data_json, 0).images.size();
  // Drop the first image record (and keep its annotation: the reader ignores unmatched ones).
  nlohmann::json data = handscs::parse_json_file(layout.data_json);
  data["images"].erase(data["images"].begin());
  handscs::write_file_atomic(layout.data_json, data.dump());
  CHECK(cache.images(layout.data_json, 0).images.size() == before - 1);
  // The rebuilt cache serves the next read.
  CHECK(cache.images(layout.data_json, 0).images.size() == before - 1);
}

TEST_CASE("annotation cache: a damaged or foreign cache file is ignored and rebuilt") {
  const std::string root = fresh_copy("cache_damaged");
  const auto layout = handscs::resolve_capture_layout(root, "test");
  const handscs::AnnotationCache cache("auto");
  const auto reference = handscs::read_interhand_joints(layout.joint_3d_json, 0);
  check_same_joints(cache.joints(layout.joint_3d_json, 0), reference);
  const std::string file = cache.files_for(layout.joint_3d_json, 0).front();
  REQUIRE(fs::is_regular_file(file));
  const std::string good = handscs::read_file(file);

  std::string flipped = good;
  flipped[flipped.size() - 10] ^= 0x55;  // a payload byte: the checksum catches it
  const std::string foreign = "{\"not\": \"a cache\"}";
  const std::string truncated = good.substr(0, good.size() / 2);
  const std::string header_only = good.substr(0, 40);
  for (const auto& damaged : {flipped, foreign, truncated, header_only, std::string()}) {
    handscs::write_file_atomic(file, damaged);
    check_same_joints(cache.joints(layout.joint_3d_json, 0), reference);
    CHECK(handscs::read_file(file) == good);  // rebuilt, byte for byte
  }
  // Another capture's cache file under this name is not trusted either.
  const std::string other = cache.files_for(layout.joint_3d_json, 1).front();
  fs::copy_file(file, other);
  CHECK_THROWS(cache.joints(layout.joint_3d_json, 1));  // capture 1 is not in the file: the reader says so
}

TEST_CASE("annotation cache: off writes nothing, a folder setting and the user cache are used") {
  const std::string root = fresh_copy("cache_where");
  const auto layout = handscs::resolve_capture_layout(root, "test");
  const auto reference = handscs::read_interhand_mano(layout.mano_json, 0);

  check_same_mano(handscs::AnnotationCache("off").mano(layout.mano_json, 0), reference);
  CHECK(handscs::AnnotationCache("off").files_for(layout.mano_json, 0).empty());
  CHECK(files_in(cache_folder(layout)) == 0);

  const std::string folder = fresh_dir("cache_where_folder");
  check_same_mano(handscs::AnnotationCache(folder).mano(layout.mano_json, 0), reference);
  CHECK(files_in(folder) == 1);
  CHECK(files_in(cache_folder(layout)) == 0);

  // The beside-data folder cannot be made (a file has its name): the user's cache folder is used.
  const std::string user = fresh_dir("cache_where_user");
  ScopedEnv xdg("XDG_CACHE_HOME", user);
  write_text(cache_folder(layout), "in the way");
  check_same_mano(handscs::AnnotationCache("auto").mano(layout.mano_json, 0), reference);
  CHECK(files_in(user + "/handscs/annotations") == 1);
  check_same_mano(handscs::AnnotationCache("auto").mano(layout.mano_json, 0), reference);
}
