// Where the caches of what handscs derives from a dataset go (data/annotation_cache.h: annotation
// extracts; data/scan_cache.h: per-image checks). One setting for all: "auto" (a .handscs-cache
// folder beside the source, if writable, else $XDG_CACHE_HOME/handscs/<kind> or
// ~/.cache/handscs/<kind>), "off", or a folder.
#pragma once

#include <string>
#include <vector>

namespace handscs {

// The cache files tried for `source` (a file or folder of the dataset), in lookup order: the first
// writable one is written. `name`: the file name beside the source; in shared folders it is
// prefixed with a hash of the source's full path, so many datasets' caches stay apart. `kind`: the
// user cache's subfolder. Empty when `setting` is "off".
std::vector<std::string> cache_files_for(const std::string& setting, const std::string& source,
                                         const std::string& name, const std::string& kind);

}  // namespace handscs
