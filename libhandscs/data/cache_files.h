// The files of the caches of what handscs derives from a dataset (data/annotation_cache.h: annotation
// extracts; data/scan_cache.h: per-image checks): where they go, one setting for all ("auto": a
// .handscs-cache folder beside the source, if writable, else $XDG_CACHE_HOME/handscs/<kind> or
// ~/.cache/handscs/<kind>; "off"; or a folder), how their payload is sealed with its size and
// checksum, and how they are written.
#pragma once

#include <string>
#include <vector>

#include "core/byte_stream.h"

namespace handscs {

// The cache files tried for `source` (a file or folder of the dataset), in lookup order: the first
// writable one is written. `name`: the file name beside the source; in shared folders it is
// prefixed with a hash of the source's full path, so many datasets' caches stay apart. `kind`: the
// user cache's subfolder. Empty when `setting` is "off".
std::vector<std::string> cache_files_for(const std::string& setting, const std::string& source,
                                         const std::string& name, const std::string& kind);

// Why a cache file is not used. `damaged`: say so as a warning; otherwise (another version wrote it,
// its source changed) rebuilding it is routine.
struct CacheRejected {
  std::string reason;
  bool damaged;
};

// A cache file's bytes: `header` (the caller's magic, version and key), the payload's size and
// checksum, the payload.
std::string sealed_cache(const std::string& header, const std::string& payload);

// The payload of a cache file's `bytes` whose header `in` has just read; throws CacheRejected when it
// is truncated or its checksum does not match (ByteStreamError when the size fields are cut off).
ByteReader sealed_payload(ByteReader& in, const std::string& bytes);

// Writes `bytes` to the first of `files` whose folder can be made and file written (atomically);
// returns that file, or "" with `problem` saying why the last one failed ("no folder": no files).
// A folder no one may write to by its permission bits is passed over, even by root.
std::string write_first_writable(const std::vector<std::string>& files, const std::string& bytes,
                                 std::string& problem);

}  // namespace handscs
