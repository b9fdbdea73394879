// Open-once cache of the per-image checks of a capture open (data/image_checks.h: the JPEG
// structure, a walk of the coded data and a 1/8-scale decode, 0.6-0.9 ms per InterHand2.6M image on
// one thread). Each scanned image's ImageScan is stored with its path (relative to the images
// folder), size and modification time (ns); a later open scans only the images that are new or whose
// size or time changed, and reads the others' results after a stat.
//
// A cache file is used only when its header matches (format, kImageChecksVersion, the checks'
// constants, OpenCV's version) and its payload's checksum matches; a damaged or foreign file is
// reported, ignored and rewritten. Every usable file of the lookup order is read and merged, and the
// first writable one written. Not stored: images that could not be stat-ed, and unreadable ones
// with no damage named (a permission or I/O error looks the same and leaves the stamp unchanged
// when fixed). Not noticed: a change that keeps an image's size and time stamp (tools that preserve
// times, bit rot, a rewrite within the file system's time granularity). Writes are atomic and keep
// the entries of images not opened this time; of two processes writing at once the last one wins,
// and the other's new entries are checked again at a later open.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "data/image_checks.h"

namespace handscs {

struct ScanCounts {
  size_t cached = 0;   // results read from the cache
  size_t scanned = 0;  // images scanned (new, changed, or no usable cache)
};

// The cache files of one capture's images folder under `setting` ("auto", "off" or a folder; see
// data/cache_files.h), in lookup order.
std::vector<std::string> scan_cache_files(const std::string& setting, const std::string& images_dir,
                                          int capture);

// scan_image of every path, in order, in parallel: from the first usable file of `cache_files`
// where an image's size and time match, else scanned, and then stored in the first writable file
// (empty `cache_files`: no cache). Stored paths are relative to `images_dir`. Never throws for a
// cache problem (it warns and scans).
std::vector<ImageScan> scan_images(const std::vector<std::string>& paths,
                                   const std::vector<std::string>& cache_files,
                                   const std::string& images_dir, ScanCounts* counts = nullptr);

}  // namespace handscs
