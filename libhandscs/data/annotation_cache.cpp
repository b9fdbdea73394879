#include "data/annotation_cache.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>

#include "core/atomic_file.h"
#include "core/byte_stream.h"
#include "core/error.h"
#include "core/file_stamp.h"
#include "core/hash.h"
#include "data/cache_files.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[] = "HANDSCS-ANNOTATION-CACHE";
// Bump whenever the readers or the encoding below change what a capture's extract holds: files of
// another version are rebuilt, never read.
constexpr uint32_t kFormatVersion = 1;
// Bytes hashed at each end of a source file: catches a rewrite that kept the size and landed within
// the file system's timestamp granularity, for the cost of two small reads.
constexpr size_t kEdgeBytes = size_t{64} << 10;

// What identifies one version of a source file.
struct SourceStamp {
  std::string name;  // file name only: a dataset folder that is moved keeps its caches
  FileStamp file;
  uint64_t edges_hash = 0;
  bool operator==(const SourceStamp& o) const {
    return name == o.name && file == o.file && edges_hash == o.edges_hash;
  }
};

SourceStamp stamp_of(const std::string& source) {
  SourceStamp stamp;
  if (!read_file_stamp(source, stamp.file)) throw Error(source + ": cannot open file");
  stamp.name = fs::path(source).filename().string();
  std::ifstream file(source, std::ios::binary);
  if (!file) throw Error(source + ": cannot open file");
  std::string edges(2 * kEdgeBytes, '\0');
  file.read(&edges[0], static_cast<std::streamsize>(kEdgeBytes));
  size_t got = static_cast<size_t>(file.gcount());
  if (stamp.file.size > kEdgeBytes) {
    const uint64_t tail = std::min<uint64_t>(kEdgeBytes, stamp.file.size - kEdgeBytes);
    file.clear();
    file.seekg(-static_cast<std::streamoff>(tail), std::ios::end);
    file.read(&edges[got], static_cast<std::streamsize>(tail));
    got += static_cast<size_t>(file.gcount());
  }
  stamp.edges_hash = fnv1a64(edges.data(), got);
  return stamp;
}

void write_header(ByteWriter& out, const char* kind, int capture, const SourceStamp& stamp) {
  out.put_array(kMagic, sizeof(kMagic));
  out.put(kFormatVersion);
  out.put_string(kind);
  out.put<int32_t>(capture);
  out.put_string(stamp.name);
  out.put(stamp.file.size);
  out.put(stamp.file.mtime_ns);
  out.put(stamp.edges_hash);
}

// Checks the header against what is wanted; throws CacheRejected or ByteStreamError.
void check_header(ByteReader& in, const char* kind, int capture, const SourceStamp& stamp) {
  char magic[sizeof(kMagic)];
  if (in.remaining() < sizeof(kMagic)) throw CacheRejected{"not a handscs annotation cache", true};
  in.get_array(magic, sizeof(kMagic));
  if (std::memcmp(magic, kMagic, sizeof(kMagic)) != 0)
    throw CacheRejected{"not a handscs annotation cache", true};
  const uint32_t version = in.get<uint32_t>();
  if (version != kFormatVersion)
    throw CacheRejected{"written by another version (format " + std::to_string(version) + ")", false};
  if (in.get_string() != kind) throw CacheRejected{"holds another kind of annotation", true};
  if (in.get<int32_t>() != capture) throw CacheRejected{"holds another capture", true};
  SourceStamp cached;
  cached.name = in.get_string();
  cached.file.size = in.get<uint64_t>();
  cached.file.mtime_ns = in.get<int64_t>();
  cached.edges_hash = in.get<uint64_t>();
  if (!(cached == stamp)) throw CacheRejected{stamp.name + " changed since it was cached", false};
}

// ---- encodings of the three extracts ----

void encode_images(ByteWriter& out, const CaptureImages& value) {
  out.put<uint64_t>(value.catalogue.captures.size());
  for (int capture : value.catalogue.captures) out.put<int32_t>(capture);
  out.put<uint64_t>(value.catalogue.sequences.size());
  for (const auto& seq : value.catalogue.sequences) out.put_string(seq);
  out.put<uint64_t>(value.images.size());
  for (const auto& image : value.images) {
    out.put(image.id);
    out.put_string(image.file_name);
    out.put<int32_t>(image.width);
    out.put<int32_t>(image.height);
    out.put<int32_t>(image.capture);
    out.put<int32_t>(image.subject);
    out.put_string(image.seq_name);
    out.put_string(image.camera);
    out.put(image.frame_idx);
    out.put_array(image.bbox.data(), image.bbox.size());
    out.put_array(image.joint_valid.data(), image.joint_valid.size());
    out.put_string(image.hand_type);
    out.put<uint8_t>(image.hand_type_valid);
  }
}

CaptureImages decode_images(ByteReader& in) {
  CaptureImages value;
  for (uint64_t n = in.get_count(4); n > 0; --n) value.catalogue.captures.insert(in.get<int32_t>());
  for (uint64_t n = in.get_count(8); n > 0; --n) value.catalogue.sequences.insert(in.get_string());
  const uint64_t count = in.get_count(100);  // an image takes well over 100 bytes
  value.images.resize(count);
  for (auto& image : value.images) {
    image.id = in.get<int64_t>();
    image.file_name = in.get_string();
    image.width = in.get<int32_t>();
    image.height = in.get<int32_t>();
    image.capture = in.get<int32_t>();
    image.subject = in.get<int32_t>();
    image.seq_name = in.get_string();
    image.camera = in.get_string();
    image.frame_idx = in.get<int64_t>();
    in.get_array(image.bbox.data(), image.bbox.size());
    in.get_array(image.joint_valid.data(), image.joint_valid.size());
    image.hand_type = in.get_string();
    image.hand_type_valid = in.get<uint8_t>() != 0;
  }
  return value;
}

void encode_joints(ByteWriter& out, const std::map<int64_t, InterHandJoints>& frames) {
  out.put<uint64_t>(frames.size());
  for (const auto& [frame, joints] : frames) {
    out.put(frame);
    out.put_array(joints.world_mm.data(), joints.world_mm.size());
    out.put_array(joints.valid.data(), joints.valid.size());
    out.put_string(joints.hand_type);
    out.put<uint8_t>(joints.hand_type_valid);
  }
}

std::map<int64_t, InterHandJoints> decode_joints(ByteReader& in) {
  std::map<int64_t, InterHandJoints> frames;
  for (uint64_t n = in.get_count(sizeof(double) * kInterHandJoints * 3); n > 0; --n) {
    const int64_t frame = in.get<int64_t>();
    InterHandJoints& joints = frames[frame];
    in.get_array(joints.world_mm.data(), joints.world_mm.size());
    in.get_array(joints.valid.data(), joints.valid.size());
    joints.hand_type = in.get_string();
    joints.hand_type_valid = in.get<uint8_t>() != 0;
  }
  return frames;
}

void encode_hand(ByteWriter& out, const std::optional<ManoParams>& hand) {
  out.put<uint8_t>(hand.has_value());
  if (!hand) return;
  out.put_array(hand->pose.data(), hand->pose.size());
  out.put_array(hand->shape.data(), hand->shape.size());
  out.put_array(hand->trans.data(), hand->trans.size());
}

std::optional<ManoParams> decode_hand(ByteReader& in) {
  if (in.get<uint8_t>() == 0) return std::nullopt;
  ManoParams hand;
  in.get_array(hand.pose.data(), hand.pose.size());
  in.get_array(hand.shape.data(), hand.shape.size());
  in.get_array(hand.trans.data(), hand.trans.size());
  return hand;
}

void encode_mano(ByteWriter& out, const std::map<int64_t, InterHandMano>& frames) {
  out.put<uint64_t>(frames.size());
  for (const auto& [frame, mano] : frames) {
    out.put(frame);
    encode_hand(out, mano.right);
    encode_hand(out, mano.left);
  }
}

std::map<int64_t, InterHandMano> decode_mano(ByteReader& in) {
  std::map<int64_t, InterHandMano> frames;
  for (uint64_t n = in.get_count(sizeof(int64_t) + 2); n > 0; --n) {
    const int64_t frame = in.get<int64_t>();
    InterHandMano& mano = frames[frame];
    mano.right = decode_hand(in);
    mano.left = decode_hand(in);
  }
  return frames;
}

// The cached extract of `source` for `capture` from the first usable file of `files`, or `read()`
// stored in the first writable one.
template <class T>
T cached(const std::vector<std::string>& files, const std::string& source, int capture,
         const char* kind, const std::function<T()>& read,
         const std::function<void(ByteWriter&, const T&)>& encode,
         const std::function<T(ByteReader&)>& decode) {
  if (files.empty()) return read();
  const SourceStamp stamp = stamp_of(source);
  for (const auto& file : files) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) continue;
    try {
      const std::string bytes = read_file(file);
      ByteReader in(bytes.data(), bytes.size());
      check_header(in, kind, capture, stamp);
      ByteReader body = sealed_payload(in, bytes);
      T value = decode(body);
      if (body.remaining() != 0) throw CacheRejected{"bytes left after the data", true};
      spdlog::debug("{}: capture {} read from {}", source, capture, file);
      return value;
    } catch (const CacheRejected& rejected) {
      if (rejected.damaged)
        spdlog::warn("{}: ignoring this annotation cache ({}); reading {} again", file,
                     rejected.reason, source);
      else
        spdlog::info("{}: {}; reading it again", file, rejected.reason);
    } catch (const ByteStreamError& e) {
      spdlog::warn("{}: ignoring this annotation cache (damaged: {}); reading {} again", file,
                   e.what(), source);
    } catch (const Error& e) {
      spdlog::warn("ignoring an unreadable annotation cache ({}); reading {} again", e.what(), source);
    }
  }

  T value = read();
  ByteWriter payload;
  encode(payload, value);
  ByteWriter header;
  write_header(header, kind, capture, stamp);
  const std::string bytes = sealed_cache(header.bytes(), payload.bytes());
  std::string problem;
  const std::string written = write_first_writable(files, bytes, problem);
  if (!written.empty())
    spdlog::info("{}: capture {} cached in {} ({:.2f} MB); later opens read it from there", source,
                 capture, written, bytes.size() / 1e6);
  else
    spdlog::warn("{}: could not write an annotation cache ({}); later opens read the file again",
                 source, problem);
  return value;
}

}  // namespace

AnnotationCache::AnnotationCache(std::string setting) : setting_(std::move(setting)) {}

std::vector<std::string> AnnotationCache::files_for(const std::string& source, int capture) const {
  const std::string name =
      fs::path(source).filename().string() + ".capture" + std::to_string(capture) + ".cache";
  return cache_files_for(setting_, source, name, "annotations");
}

CaptureImages AnnotationCache::images(const std::string& data_json, int capture) const {
  const std::function<CaptureImages()> read = [&] {
    ImageFilter filter;
    filter.capture = capture;
    CaptureImages value;
    value.images = read_interhand_images(data_json, filter, &value.catalogue);
    return value;
  };
  return cached<CaptureImages>(files_for(data_json, capture), data_json, capture, "images", read,
                               encode_images, decode_images);
}

std::map<int64_t, InterHandJoints> AnnotationCache::joints(const std::string& joint_3d_json,
                                                           int capture) const {
  using Frames = std::map<int64_t, InterHandJoints>;
  const std::function<Frames()> read = [&] { return read_interhand_joints(joint_3d_json, capture); };
  return cached<Frames>(files_for(joint_3d_json, capture), joint_3d_json, capture, "joints", read,
                        encode_joints, decode_joints);
}

std::map<int64_t, InterHandMano> AnnotationCache::mano(const std::string& mano_json,
                                                       int capture) const {
  using Frames = std::map<int64_t, InterHandMano>;
  const std::function<Frames()> read = [&] { return read_interhand_mano(mano_json, capture); };
  return cached<Frames>(files_for(mano_json, capture), mano_json, capture, "mano", read,
                        encode_mano, decode_mano);
}

}  // namespace handscs
