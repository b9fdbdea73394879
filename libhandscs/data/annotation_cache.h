// Open-once cache of what one capture needs from InterHand2.6M's large annotation files: the first
// open streams data.json, joint_3d.json and MANO_NeuralAnnot.json (tens of seconds at the release's
// 1.4M image records) and stores the capture's extract in a small binary file; later opens of the
// same capture read that instead (well under a second).
//
// A cache file is trusted only when its header matches the source exactly: format version, kind,
// capture, the source's file name, size, modification time (ns) and a checksum of its first and
// last 64 KiB; and its payload's checksum matches. A changed source rebuilds it; a damaged or
// foreign file is reported, ignored and rebuilt. Writes are atomic, so concurrent runs are safe.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "data/interhand_annotations.h"

namespace handscs {

// data.json's images of one capture (every sequence), with what the file holds.
struct CaptureImages {
  std::vector<InterHandImage> images;
  ImageCatalogue catalogue;
};

// Where caches go (data/cache_files.h): "auto" (a .handscs-cache folder beside the annotation file
// if writable, else $XDG_CACHE_HOME/handscs/annotations or ~/.cache/handscs/annotations), "off", or
// a folder.
class AnnotationCache {
 public:
  explicit AnnotationCache(std::string setting = "auto");

  // read_interhand_images(data_json, {capture}) and its catalogue.
  CaptureImages images(const std::string& data_json, int capture) const;
  // read_interhand_joints / read_interhand_mano of one capture.
  std::map<int64_t, InterHandJoints> joints(const std::string& joint_3d_json, int capture) const;
  std::map<int64_t, InterHandMano> mano(const std::string& mano_json, int capture) const;

  // The cache files tried for `source`'s extract of `capture`, in lookup order (the first writable
  // one is written). Empty when the cache is off.
  std::vector<std::string> files_for(const std::string& source, int capture) const;

 private:
  std::string setting_;
};

}  // namespace handscs
