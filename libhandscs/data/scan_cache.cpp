#include "data/scan_cache.h"

#include <opencv2/core/version.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <unordered_map>

#include "core/atomic_file.h"
#include "core/byte_stream.h"
#include "core/error.h"
#include "core/file_stamp.h"
#include "core/text.h"
#include "data/cache_files.h"

namespace handscs {

namespace fs = std::filesystem;

// A named namespace: unity builds compile this file with annotation_cache.cpp, whose unnamed
// namespace has the same names.
namespace scan_cache_detail {

constexpr char kMagic[] = "HANDSCS-SCAN-CACHE";
// Bump whenever the encoding below changes: files of another format are rewritten, never read.
constexpr uint32_t kFormatVersion = 1;

struct Entry {
  FileStamp stamp;
  ImageScan scan;
};

using Entries = std::unordered_map<std::string, Entry>;  // relative path -> entry

// The path as stored: relative to the images folder (both normalised: "./x" and "x" are one key)
// when it lies inside it.
std::string key_of(const std::string& path, const fs::path& images_dir) {
  const fs::path relative = fs::path(path).lexically_normal().lexically_relative(images_dir);
  if (relative.empty() || *relative.begin() == "..") return path;
  return relative.generic_string();
}

// Everything a cached result depends on besides the file: written in the header, compared on read.
// OpenCV's version stands for its JPEG decoder's (the 1/8-scale decode).
void put_checks_signature(ByteWriter& out) {
  out.put<int32_t>(kImageChecksVersion);
  out.put<int32_t>(kBlackLevel);
  out.put<int32_t>(kColourSpread);
  out.put<double>(kMonochromeFraction);
  out.put_string(CV_VERSION);
}

// In path order, so the same entries always give the same bytes.
std::string encode(const Entries& entries) {
  std::vector<const Entries::value_type*> sorted;
  for (const auto& item : entries) sorted.push_back(&item);
  std::sort(sorted.begin(), sorted.end(), [](const auto* a, const auto* b) { return a->first < b->first; });
  ByteWriter payload;
  payload.put<uint64_t>(entries.size());
  for (const auto* item : sorted) {
    const auto& [key, entry] = *item;
    payload.put_string(key);
    payload.put(entry.stamp.size);
    payload.put(entry.stamp.mtime_ns);
    payload.put<uint8_t>(entry.scan.readable);
    payload.put_string(entry.scan.damage);
    payload.put<uint8_t>(entry.scan.black);
    payload.put<uint8_t>(entry.scan.monochrome);
    payload.put<int32_t>(entry.scan.width);
    payload.put<int32_t>(entry.scan.height);
  }
  ByteWriter header;
  header.put_array(kMagic, sizeof(kMagic));
  header.put(kFormatVersion);
  put_checks_signature(header);
  return sealed_cache(header.bytes(), payload.bytes());
}

// The entries of a cache file; throws CacheRejected when it is not a usable cache.
Entries decode(const std::string& bytes) {
  try {
    ByteReader in(bytes.data(), bytes.size());
    char magic[sizeof(kMagic)];
    if (in.remaining() < sizeof(kMagic)) throw CacheRejected{"not a handscs image-check cache", true};
    in.get_array(magic, sizeof(kMagic));
    if (std::memcmp(magic, kMagic, sizeof(kMagic)) != 0)
      throw CacheRejected{"not a handscs image-check cache", true};
    if (in.get<uint32_t>() != kFormatVersion) throw CacheRejected{"written in another format", false};
    ByteWriter want;
    put_checks_signature(want);
    std::string signature(want.bytes().size(), '\0');
    in.get_array(&signature[0], signature.size());
    if (signature != want.bytes()) throw CacheRejected{"written by another version of the checks", false};
    ByteReader body = sealed_payload(in, bytes);
    Entries entries;
    // Each entry is at least a path length, the stamp, three flags, a damage length and two sizes.
    for (uint64_t n = body.get_count(8 + 16 + 3 + 8 + 8); n > 0; --n) {
      const std::string key = body.get_string();
      Entry& entry = entries[key];
      entry.stamp.size = body.get<uint64_t>();
      entry.stamp.mtime_ns = body.get<int64_t>();
      entry.scan.readable = body.get<uint8_t>() != 0;
      entry.scan.damage = body.get_string();
      entry.scan.black = body.get<uint8_t>() != 0;
      entry.scan.monochrome = body.get<uint8_t>() != 0;
      entry.scan.width = body.get<int32_t>();
      entry.scan.height = body.get<int32_t>();
    }
    if (body.remaining() != 0) throw CacheRejected{"bytes left after the entries", true};
    return entries;
  } catch (const ByteStreamError& e) {
    throw CacheRejected{std::string("damaged: ") + e.what(), true};
  }
}

// The entries of every usable file, merged (earlier files first: each entry is checked against its
// image's stamp anyway, so a valid entry is valid wherever it was found), and the files read. All
// files, not the first: when the first place cannot be written, new entries go to a later one.
std::pair<Entries, std::vector<std::string>> read_usable(const std::vector<std::string>& files) {
  Entries merged;
  std::vector<std::string> read;
  for (const auto& file : files) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) continue;
    try {
      Entries entries = decode(read_file(file));
      merged.insert(entries.begin(), entries.end());  // keeps an earlier file's entry
      read.push_back(file);
    } catch (const CacheRejected& rejected) {
      if (rejected.damaged)
        spdlog::warn("{}: ignoring this image-check cache ({})", file, rejected.reason);
      else
        spdlog::info("{}: {}; its images are checked again", file, rejected.reason);
    } catch (const std::exception& e) {
      spdlog::warn("ignoring an unreadable image-check cache ({})", e.what());
    }
  }
  return {merged, read};
}

void write(const std::vector<std::string>& files, const Entries& entries) {
  std::string bytes, problem;
  try {
    bytes = encode(entries);
  } catch (const std::exception& e) {
    spdlog::warn("could not encode the image-check cache ({}); later opens check the images again", e.what());
    return;
  }
  const std::string written = write_first_writable(files, bytes, problem);
  if (!written.empty())
    spdlog::info("image checks of {} images cached in {} ({:.2f} MB); later opens read them",
                 entries.size(), written, bytes.size() / 1e6);
  else
    spdlog::warn("could not write an image-check cache ({}); later opens check the images again",
                 problem);
}

}  // namespace scan_cache_detail

std::vector<std::string> scan_cache_files(const std::string& setting, const std::string& images_dir,
                                          int capture) {
  const std::string name = fs::path(images_dir).lexically_normal().filename().string() + ".capture" +
                           std::to_string(capture) + ".scans";
  return cache_files_for(setting, fs::path(images_dir).lexically_normal().string(), name, "scans");
}

std::vector<ImageScan> scan_images(const std::vector<std::string>& paths,
                                   const std::vector<std::string>& cache_files,
                                   const std::string& images_dir, ScanCounts* counts) {
  namespace detail = scan_cache_detail;
  auto [entries, sources] = detail::read_usable(cache_files);
  const fs::path root = fs::path(images_dir).lexically_normal();
  const int64_t n = static_cast<int64_t>(paths.size());
  std::vector<ImageScan> scans(paths.size());
  std::vector<std::string> keys(paths.size());
  std::vector<FileStamp> stamps(paths.size());
  // 0: read from the cache; 1: scanned, to be stored; 2: scanned, not stored.
  std::vector<uint8_t> state(paths.size(), 0);
#pragma omp parallel for schedule(dynamic, 4)
  for (int64_t i = 0; i < n; ++i) {  // nothing here throws but allocation
    keys[i] = detail::key_of(paths[i], root);
    const bool stat_ok = read_file_stamp(paths[i], stamps[i]);
    const auto found = stat_ok ? entries.find(keys[i]) : entries.end();
    if (found != entries.end() && found->second.stamp == stamps[i]) {
      scans[i] = found->second.scan;
    } else {
      scans[i] = scan_image(paths[i]);
      // Not stored: a file that could not be stat-ed, or read or decoded with no damage named (a
      // permission, an I/O error or memory can be the cause, and none of them changes the stamp
      // when it is fixed); such a file is checked again at every open. An oversized header is
      // named but not stored either (the cache has no field for it): a read, never a decode.
      const bool unexplained = !scans[i].readable && scans[i].damage.empty();
      state[i] = stat_ok && !unexplained ? 1 : 2;
    }
  }
  ScanCounts counted;
  bool changed = false;
  for (int64_t i = 0; i < n; ++i) {
    if (state[i] == 0) {
      ++counted.cached;
      continue;
    }
    ++counted.scanned;
    if (state[i] == 1) {
      entries[keys[i]] = {stamps[i], scans[i]};
      changed = true;
    }
  }
  if (!cache_files.empty())
    spdlog::info("image checks: {} from the cache{}, {} scanned", counted.cached,
                 sources.empty() ? "" : " (" + join(sources, ", ") + ")", counted.scanned);
  if (changed && !cache_files.empty()) detail::write(cache_files, entries);
  if (counts) *counts = counted;
  return scans;
}

}  // namespace handscs
