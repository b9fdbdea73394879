#include "data/cache_files.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/hash.h"

namespace handscs {

namespace fs = std::filesystem;

namespace {

constexpr char kBesideFolder[] = ".handscs-cache";

// The user's cache folder for caches of `kind`, "" when neither variable is set.
std::string user_cache_folder(const std::string& kind) {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return (fs::path(xdg) / "handscs" / kind).string();
  if (const char* home = std::getenv("HOME"); home && *home)
    return (fs::path(home) / ".cache" / "handscs" / kind).string();
  return "";
}

// The folder a cache file would be made in, or the nearest folder above it that exists, when no
// one may write to it by its permission bits (a dataset unpacked read-only). Root passes every
// access() test, so the bits are read instead: a run as root would otherwise fill read-only data
// with cache folders. "" when writing there is allowed.
std::string read_only_folder(const fs::path& file) {
  std::error_code ec;
  fs::path folder = file.parent_path();
  while (!folder.empty() && !fs::exists(folder, ec)) {
    if (folder == folder.parent_path()) return "";
    folder = folder.parent_path();
  }
  if (folder.empty()) folder = ".";  // a relative path none of whose folders exist yet
  const fs::perms perms = fs::status(folder, ec).permissions();
  if (ec) return "";
  const fs::perms write = fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write;
  return (perms & write) == fs::perms::none ? folder.string() : "";
}

}  // namespace

std::vector<std::string> cache_files_for(const std::string& setting, const std::string& source,
                                         const std::string& name, const std::string& kind) {
  if (setting == "off") return {};
  const fs::path path(source);
  std::error_code ec;
  fs::path canonical = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) canonical = path;
  const std::string key = canonical.string();
  const std::string shared_name = hex16(fnv1a64(key.data(), key.size())) + "-" + name;
  if (setting != "auto") return {(fs::path(setting) / shared_name).string()};
  std::vector<std::string> files{(canonical.parent_path() / kBesideFolder / name).string()};
  const std::string user = user_cache_folder(kind);
  if (!user.empty()) files.push_back((fs::path(user) / shared_name).string());
  return files;
}

std::string sealed_cache(const std::string& header, const std::string& payload) {
  ByteWriter sizes;
  sizes.put<uint64_t>(payload.size());
  sizes.put<uint64_t>(fnv1a64(payload));
  return header + sizes.bytes() + payload;
}

ByteReader sealed_payload(ByteReader& in, const std::string& bytes) {
  const uint64_t payload_size = in.get<uint64_t>();
  const uint64_t payload_hash = in.get<uint64_t>();
  if (payload_size != in.remaining())
    throw CacheRejected{"truncated (" + std::to_string(in.remaining()) + " of " +
                            std::to_string(payload_size) + " payload bytes)",
                        true};
  const char* payload = bytes.data() + (bytes.size() - payload_size);
  if (fnv1a64(payload, payload_size) != payload_hash) throw CacheRejected{"checksum mismatch", true};
  return ByteReader(payload, payload_size);
}

std::string write_first_writable(const std::vector<std::string>& files, const std::string& bytes,
                                 std::string& problem) {
  problem = "no folder";
  for (const auto& file : files) {
    if (const std::string folder = read_only_folder(file); !folder.empty()) {
      problem = folder + ": read-only folder (no write permission for anyone)";
      continue;
    }
    try {
      ensure_directory(fs::path(file).parent_path().string());
      write_file_atomic(file, bytes);
      return file;
    } catch (const std::exception& e) {
      problem = e.what();
    }
  }
  return "";
}

}  // namespace handscs
