// Configuration of one training capture (InterHand2.6M's layout, the project's own or EasyMocap's:
// docs/CAPTURE_FORMAT.md): which images (split, capture, sequences, hand, cameras, stride), the
// train/test split rule, masks and caching.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/config.h"
#include "data/mask_refine.h"
#include "hand/keypoint_fit.h"
#include "hand/rig.h"

namespace handscs {

// Decoded-crop cache and background prefetching (memory stays bounded whatever the capture size).
struct CropCacheConfig {
  // ~1 GiB holds about 6,000 ROI crops of a 512x334 capture (about 170 KB each with the mask):
  // a 20,000-image capture then trains within 4 GB resident together with the model.
  int64_t budget_mb = 1024;  // byte budget of the in-memory LRU cache of ROI crops (MiB)
  int prefetch_threads = 1;  // background loader threads (0 = load on demand only)
  bool disk_masks = true;    // cache computed masks as PNG files in the run's mask folder

  template <class V>
  void visit(V& v) {
    v.field("budget_mb", budget_mb, "in-memory LRU cache of decoded ROI crops (MiB)", 0, 1 << 20);
    v.field("prefetch_threads", prefetch_threads, "background image loader threads", 0, 64);
    v.field("disk_masks", disk_masks, "cache masks as PNG files next to the run");
  }
};

struct CaptureConfig {
  // The capture folder's layout (docs/CAPTURE_FORMAT.md). automatic ("auto" in files): easymocap
  // when root holds intri.yml, handscs when it holds capture.json, neus when it holds a NeuS/IDR
  // camera archive, else interhand.
  enum class Layout { automatic, interhand, handscs, easymocap, neus };
  // novel_pose: the last held_out_poses poses are the test set; novel_view: test cameras are.
  enum class SplitRule { novel_pose, novel_view };
  // Where each frame's hand pose comes from (InterHand2.6M layout).
  enum class PoseSource { mano, joints };
  // The hands a run trains: one of them, or both (an avatar each, rendered together).
  enum class Hands { right, left, both };
  // Masks that come with a capture: used as given, replaced by the posed meshes' mask where they
  // disagree with the posed hands (IoU < 0.3, a broken mask), or not read at all.
  enum class SuppliedMasks { use, replace_poor, ignore };

  std::string root;                        // dataset folder (see layout)
  Layout layout = Layout::automatic;
  std::string hands_file;                  // neus layout: the hands' MANO parameters (capture.json form)
  std::string split = "test";              // InterHand split folder: train, test or val
  int capture = 0;                         // Capture{c} (InterHand2.6M layout only)
  std::vector<std::string> sequences;      // seq_name values to use (empty = all of the capture)
  // Which hands' MANO parameters drive the avatars. both: every frame with either hand, each hand
  // its own avatar, masks and crops covering both; a hand without parameters in a frame is absent
  // from it while the other trains.
  Hands hand = Hands::right;
  bool include_interacting = false;        // one hand: also use frames annotated "interacting"
  SuppliedMasks supplied_masks = SuppliedMasks::use;
  std::vector<std::string> train_cameras;  // camera ids for training (empty = all; see split_rule)
  std::vector<std::string> test_cameras;   // camera ids for testing (empty: as train_cameras)
  int frame_stride = 1;                    // keep every k-th pose (by frame index)
  bool drop_monochrome = true;             // drop cameras whose images are grey (R = G = B)
  bool skip_black_images = true;           // skip frames whose image is black (camera dropout)
  SplitRule split_rule = SplitRule::novel_pose;  // which images test (see SplitRule)
  int held_out_poses = 50;                 // poses held out by novel_pose (the paper: 50)
  // novel_pose: train on only the last train_poses poses before the held-out tail (0 = all of
  // them). Runs with different counts on one capture then share the same test images, so a
  // study of the number of training poses changes nothing else.
  int train_poses = 0;
  // novel_pose: > 0 makes the last validation_poses training poses the test set and leaves the
  // held-out poses unused, so that a choice is made without ever seeing the test poses.
  int validation_poses = 0;
  // novel_view: these training cameras become the test set and leave training; the test cameras
  // are then unused, so that a choice is made without ever seeing the test views. A monochrome
  // camera is refused while drop_monochrome drops its images.
  std::vector<std::string> validation_cameras;
  // novel_view without camera lists: this many cameras, evenly spaced over the sorted ids, test
  // views interleaved between training views (the paper: 10 train, 15 test; its exact ids are in a
  // supplement we do not have). Counted before monochrome cameras are dropped.
  int novel_view_train_views = 10;
  int novel_view_test_views = 15;
  // mano: the MANO_NeuralAnnot file; joints: the rig fitted to joint_3d.json (no MANO file or
  // licence needed; docs/FIT.md).
  PoseSource pose_source = PoseSource::mano;
  KeypointFitConfig joint_fit;  // pose_source = joints: the fit's settings
  // pose_source = joints: a hand whose mean joint residual exceeds this (mm) is skipped as "poor
  // joint fit". Real InterHand2.6M joints fit the built-in hand to 2-3 mm on average (docs/FIT.md);
  // 15 mm means mislabelled joints, never a usable pose.
  double poor_joint_fit_mm = 15.0;
  std::string rig = "builtin";             // rig of the masks and (in a run) the avatar
  bool flat_hand_mean = false;  // false: annotated poses are relative to hands_mean (InterHand)
  int roi_margin = 16;          // pixels added around the mask's bounding box
  // Where the capture's extract of the annotation files is kept so that later opens skip the
  // multi-GB JSON (data/annotation_cache.h): "auto" (beside the annotations if writable, else
  // ~/.cache/handscs/annotations), "off", or a folder.
  std::string annotation_cache = "auto";
  // Where the per-image checks' results are kept so that later opens check only new or changed
  // images (data/scan_cache.h): the same choices as annotation_cache (beside the images folder).
  std::string scan_cache = "auto";
  MaskRefineConfig mask_refine;
  CropCacheConfig cache;

  template <class V>
  void visit(V& v) {
    v.field("root", root, "capture folder (docs/CAPTURE_FORMAT.md)");
    v.choice("layout", layout, layout_names(),
             "capture layout; auto: easymocap with intri.yml, handscs with capture.json, neus with "
             "camera/param.npz, cameras.npz or cameras_sphere.npz, else interhand");
    v.field("hands_file", hands_file,
            "neus layout: JSON file of the hands' MANO parameters (frames as in capture.json; "
            "handscs-fit --multiview writes one)");
    v.choice("split", split, {"train", "test", "val"}, "InterHand2.6M split folder");
    v.field("capture", capture, "InterHand2.6M capture number (images/{split}/Capture{c})", 0,
            1000000);
    v.field("sequences", sequences, "sequence names to use (empty = all)");
    v.choice("hand", hand, hand_names(),
             "hand whose MANO parameters are used; both: an avatar for each hand of every frame");
    v.field("include_interacting", include_interacting,
            "one hand: also use frames whose hand_type is interacting (the other hand is in view)");
    v.choice("supplied_masks", supplied_masks, supplied_masks_names(),
             "masks that come with the capture: use them; replace_poor: the posed meshes' mask where "
             "one overlaps the posed hands by IoU < 0.3; ignore: always the posed meshes' mask");
    v.field("train_cameras", train_cameras, "training camera ids (empty = all)");
    v.field("test_cameras", test_cameras,
            "test camera ids (novel_pose: empty = as train_cameras; novel_view: empty = chosen "
            "with train_cameras by novel_view_*_views)");
    v.field("frame_stride", frame_stride, "keep every k-th pose by frame index", 1, 1000000);
    v.field("drop_monochrome", drop_monochrome, "drop monochrome (R=G=B) cameras");
    v.field("skip_black_images", skip_black_images, "skip black (dropped-out) images");
    v.choice("split_rule", split_rule, split_rule_names(),
             "novel_pose: hold out the last poses; novel_view: train vs test cameras");
    v.field("held_out_poses", held_out_poses, "poses held out by novel_pose", 1, 1000000);
    v.field("train_poses", train_poses,
            "novel_pose: train on the last N poses before the held-out ones (0 = all)", 0, 1000000);
    v.field("validation_poses", validation_poses,
            "novel_pose: test on the last N training poses instead of the held-out ones, which "
            "are then unused (0 = off)", 0, 1000000);
    v.field("validation_cameras", validation_cameras,
            "novel_view: test on these training cameras (no longer trained on) instead of the "
            "test cameras, which are then unused (empty = off)");
    v.field("novel_view_train_views", novel_view_train_views,
            "novel_view without camera lists: number of training cameras chosen", 1, 100000);
    v.field("novel_view_test_views", novel_view_test_views,
            "novel_view without camera lists: number of test cameras chosen", 1, 100000);
    v.choice("pose_source", pose_source, pose_source_names(),
             "InterHand2.6M: hand poses from MANO_NeuralAnnot (mano) or fitted to joint_3d.json (joints)");
    v.section("joint_fit", joint_fit, "pose_source joints: the rig fitted to each frame's joints");
    v.field("poor_joint_fit_mm", poor_joint_fit_mm,
            "pose_source joints: skip a hand whose mean joint residual (mm) exceeds this", 0.1, 1e6);
    v.field("rig", rig,
            "rig of the masks and the avatar: builtin (the hand of data.hand), builtin:left, "
            "builtin+fingers (with per-finger length modes, for poses fitted to real joints) or a rig "
            "file (hand must match; both: the file's mirror image is the other hand)");
    v.field("flat_hand_mean", flat_hand_mean,
            "poses are absolute (true) or relative to hands_mean (masks and avatar)");
    v.field("roi_margin", roi_margin, "pixels around the mask's bounding box", 0, 4096);
    v.field("annotation_cache", annotation_cache,
            "cache of the capture's annotations for fast reopening: auto (a .handscs-cache folder "
            "beside them if writable, else ~/.cache/handscs), off, or a folder");
    v.field("scan_cache", scan_cache,
            "cache of the per-image checks (JPEG damage, 1/8 decode) for fast reopening: auto (a "
            ".handscs-cache folder beside the images if writable, else ~/.cache/handscs), off, or a "
            "folder");
    v.section("mask_refine", mask_refine, "mask refinement against the image");
    v.section("cache", cache, "image cache and prefetching");
  }

  // Each choice's names as files write them (and --help lists them).
  static const ChoiceNames<Layout>& layout_names();
  static const ChoiceNames<Hands>& hand_names();
  static const ChoiceNames<SplitRule>& split_rule_names();
  static const ChoiceNames<PoseSource>& pose_source_names();
  static const ChoiceNames<SuppliedMasks>& supplied_masks_names();
};

// A choice's name as config files write it, for messages and cache keys ("interhand", "left",
// "novel_view", "joints").
std::string layout_name(CaptureConfig::Layout layout);
std::string hand_name(Handedness hand);
std::string hand_name(CaptureConfig::Hands hands);
// The hands `hands` trains, right first.
std::vector<Handedness> hand_sides(CaptureConfig::Hands hands);
// The one hand of a one-hand selection; throws Error for both, naming `what` (the part of the
// toolchain that handles one hand only).
Handedness single_hand(CaptureConfig::Hands hands, const std::string& what);
std::string split_rule_name(CaptureConfig::SplitRule rule);
std::string pose_source_name(CaptureConfig::PoseSource source);

}  // namespace handscs
