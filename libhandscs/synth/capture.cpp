#include "synth/capture.h"

#include <spdlog/spdlog.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <set>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <limits>
#include <optional>

#include "core/atomic_file.h"
#include "core/available_memory.h"
#include "core/config.h"
#include "core/csv_table.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/stop_signal.h"
#include "core/threads.h"
#include "data/capture_layout.h"
#include "data/mesh_mask.h"
#include "hand/joint_order.h"
#include "hand/lbs.h"
#include "synth/fit_error.h"
#include "synth/gestures.h"
#include "synth/left_hand.h"
#include "synth/mirror.h"
#include "synth/own_layouts.h"
#include "synth/regions.h"
#include "synth/render_memory.h"
#include "synth/shadows.h"

namespace handscs {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace synth;

namespace {

// World position of the hand's centre (m): away from the origin (like InterHand's world frame,
// where hands sit about a metre from the origin) so that unit or translation mistakes show.
const Vec3 kHandCentre = {0.03, -0.08, 1.05};
// Slow drift of the hand around its centre (m), so trans varies as in real captures.
constexpr double kDrift = 0.008;

// One row per pose: its sequence and frame index (the images' imageN.jpg), whether it is in the
// held-out tail (the poses data.held_out_poses = held_out_frames holds out with frame_stride 1 and
// no pose lost to skipped images), the gesture the hand moves to ("" in range of motion) and
// whether any training pose moves to that gesture; for scoring held-out frames by kind
// (tools/study/frame_groups.py).
CsvTable frames_csv(const SynthScene& scene, int held_out_frames) {
  const int64_t n = static_cast<int64_t>(scene.frames.size());
  const int64_t first_held_out = n - std::min<int64_t>(n, std::max(0, held_out_frames));
  std::set<std::string> trained;
  for (int64_t k = 0; k < first_held_out; ++k) trained.insert(scene.frames[k].gesture);
  CsvTable table;
  table.header = {"seq_name", "frame_idx", "held_out", "gesture", "gesture_in_training"};
  for (int64_t k = 0; k < n; ++k) {
    const SynthFrame& f = scene.frames[k];
    const std::string in_training = f.gesture.empty() ? "" : trained.count(f.gesture) ? "1" : "0";
    table.rows.push_back({f.seq_name, std::to_string(f.frame_idx), k >= first_held_out ? "1" : "0",
                          f.gesture, in_training});
  }
  return table;
}

// "0000_synth_rom" (range of motion) or "0000_synth_gestures".
std::string sequence_name(int index, const char* motion) {
  char name[48];
  std::snprintf(name, sizeof(name), "%04d_synth_%s", index, motion);
  return name;
}

std::string image_file_name(const SynthScene& scene, const SynthFrame& frame,
                            const SynthCamera& camera) {
  return "Capture" + std::to_string(scene.config.capture) + "/" + frame.seq_name + "/cam" +
         camera.id + "/image" + std::to_string(frame.frame_idx) + ".jpg";
}

std::string region_file_name(const std::string& image_name) {
  return image_name.substr(0, image_name.size() - 4) + ".png";
}

// Flexion of the joints under the skin's creases, as fractions of a right angle.
SkinFlexion skin_flexion(const HandArticulation& a) {
  SkinFlexion flexion;
  for (int f = 0; f < kFingers; ++f)
    for (int k = 0; k < 3; ++k) flexion.joint[f * 3 + k] = std::max(0.0, a.flex[f][k] / kFlexionUnit);
  flexion.palm_fold = palm_fold(a);
  return flexion;
}

// Gap between the two hands' boxes along the thumbs' axis (m), hand both: it swings between a
// 1.5 cm overlap (the thumbs touch, pass each other or hide one another) and 2.5 cm apart, once
// every kGapPeriod frames.
constexpr double kGapMiddle = 0.005;
constexpr double kGapSwing = 0.02;
constexpr double kGapPeriod = 16;

// One hand's motion: poses, gestures, fit errors and the posed meshes at zero translation.
struct HandMotion {
  std::vector<SynthPose> poses;
  std::vector<std::string> gestures;
  std::vector<FitError> errors;
  torch::Tensor vertices, joints;  // [n, V, 3], [n, 21, 3] double
};

// shapes_from: another motion whose per-frame shapes this one takes (the same person's other hand).
HandMotion make_hand_motion(const Rig& rig, const SynthConfig& config, uint64_t seed,
                            const std::vector<SynthPose>* shapes_from) {
  const SynthEffects& effects = config.effects;
  HandMotion m;
  m.poses = effects.gestures ? make_gesture_poses(rig, config.num_frames, config.held_out_frames,
                                                  seed, &m.gestures)
                             : make_rom_poses(rig, config.num_frames, seed);
  if (shapes_from)
    for (size_t k = 0; k < m.poses.size(); ++k) m.poses[k].shape = (*shapes_from)[k].shape;
  m.errors = effects.fit_error ? make_fit_errors(effects, config.num_frames, seed)
                               : std::vector<FitError>(config.num_frames);
  const int64_t n = config.num_frames;
  const auto options = torch::TensorOptions().dtype(torch::kFloat64);
  torch::Tensor pose = torch::empty({n, 48}, options), shape = torch::empty({n, 10}, options);
  for (int64_t k = 0; k < n; ++k) {
    std::copy(m.poses[k].pose.begin(), m.poses[k].pose.end(), pose[k].data_ptr<double>());
    std::copy(m.poses[k].shape.begin(), m.poses[k].shape.end(), shape[k].data_ptr<double>());
  }
  // Posed in chunks: LBS holds ~220 KB of intermediates a frame (per-vertex transforms), so posing
  // 20,000 frames at once asked for 4.3 GB, while the posed meshes kept are ~20 KB a frame.
  constexpr int64_t kFramesPerLbs = 512;
  std::vector<torch::Tensor> vertex_chunks, joint_chunks;
  torch::NoGradGuard no_grad;
  LbsOptions lbs_options;
  lbs_options.flat_hand_mean = true;  // absolute poses here; the files get pose - hands_mean
  for (int64_t begin = 0; begin < n; begin += kFramesPerLbs) {
    const int64_t count = std::min(kFramesPerLbs, n - begin);
    const LbsOutput posed = lbs(rig, pose.narrow(0, begin, count), shape.narrow(0, begin, count),
                                torch::zeros({count, 3}, options), lbs_options);
    vertex_chunks.push_back(posed.vertices);
    joint_chunks.push_back(posed.joints);
  }
  m.vertices = torch::cat(vertex_chunks).contiguous();
  m.joints = torch::cat(joint_chunks).contiguous();
  return m;
}

// Extent of a posed mesh [V, 3] along world axis d (m).
double box_extent(const torch::Tensor& vertices, int d) {
  const torch::Tensor column = vertices.select(1, d);
  return column.max().item<double>() - column.min().item<double>();
}

// Frame k of `m` translated so that its box centre sits at anchor + drift.
SynthFrame place_hand(const HandMotion& m, int64_t k, const Vec3& anchor, const Vec3& drift,
                      const double* hands_mean) {
  SynthFrame frame;
  const SynthPose& pose = m.poses[k];
  const FitError& error = m.errors[k];
  frame.absolute = pose;
  for (int i = 0; i < 48; ++i) frame.annotated[i] = pose.pose[i] + error.pose[i];
  for (int i = 0; i < 45; ++i) frame.annotated[3 + i] -= hands_mean[i];
  for (int i = 0; i < 10; ++i) frame.annotated_shape[i] = pose.shape[i] + error.shape[i];
  const double* v = m.vertices[k].data_ptr<double>();
  const int64_t num_vertices = m.vertices.size(1);
  Vec3 lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY};
  for (int64_t i = 0; i < num_vertices; ++i)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], v[i * 3 + d]);
      hi[d] = std::max(hi[d], v[i * 3 + d]);
    }
  for (int d = 0; d < 3; ++d) frame.trans[d] = anchor[d] - 0.5 * (lo[d] + hi[d]) + drift[d];
  for (int d = 0; d < 3; ++d) frame.annotated_trans[d] = frame.trans[d] + error.trans[d];
  frame.vertices.resize(num_vertices * 3);
  for (int64_t i = 0; i < num_vertices; ++i)
    for (int d = 0; d < 3; ++d)
      frame.vertices[i * 3 + d] = static_cast<float>(v[i * 3 + d] + frame.trans[d]);
  const double* j = m.joints[k].data_ptr<double>();
  for (int i = 0; i < 21; ++i)
    for (int d = 0; d < 3; ++d) frame.joints[i * 3 + d] = j[i * 3 + d] + frame.trans[d];
  return frame;
}

// Normals, soft tissue, fold occlusion and the forearm of a placed hand.
void finish_surface(const SynthScene& scene, const TissueRig& tissue, SynthFrame& frame) {
  const SynthEffects& effects = scene.config.effects;
  frame.normals = vertex_normals(frame.vertices, scene.faces);
  if (effects.tissue) {
    const TissueResult result = tissue_displacement(tissue, effects, frame.absolute.articulation,
                                                    frame.vertices, frame.normals);
    apply_displacement(result, frame.normals, frame.vertices);
    frame.contact = result.contact;
    frame.normals = vertex_normals(frame.vertices, scene.faces);
  }
  frame.occlusion = effects.ambient_occlusion
                        ? fold_occlusion(frame.vertices, frame.normals)
                        : std::vector<float>(frame.vertices.size() / 3, 0.0f);
  if (effects.forearm) {
    frame.forearm = pose_forearm(scene.forearm, scene.axes, frame.absolute.articulation,
                                 {frame.joints[0], frame.joints[1], frame.joints[2]});
    frame.forearm_normals = vertex_normals(frame.forearm, scene.forearm.faces);
  }
}

// Several posed parts rendered as one mesh (the z-buffer sorts out which hides which).
struct JoinedMesh {
  std::vector<float> vertices, normals, occlusion, texture, nail, palmar, visibility, contact;
  std::vector<int64_t> faces;
  int64_t second_hand_face = std::numeric_limits<int64_t>::max();

  void add(const std::vector<float>& v, const std::vector<float>& n, const std::vector<int64_t>& f) {
    const int64_t offset = static_cast<int64_t>(vertices.size() / 3);
    vertices.insert(vertices.end(), v.begin(), v.end());
    normals.insert(normals.end(), n.begin(), n.end());
    for (int64_t id : f) faces.push_back(id + offset);
  }
  static void append(std::vector<float>& to, const std::vector<float>& values, size_t count,
                     float fill) {
    if (values.empty()) to.insert(to.end(), count, fill);
    else to.insert(to.end(), values.begin(), values.end());
  }
  void add_hand(const SynthFrame& hand, const std::vector<int64_t>& faces_of_hand,
                const SynthSkin& skin) {
    const size_t count = hand.vertices.size() / 3;
    add(hand.vertices, hand.normals, faces_of_hand);
    append(occlusion, hand.occlusion, count, 0.0f);
    append(texture, skin.canonical, count * 3, 0.0f);
    append(nail, skin.nail, count, 0.0f);
    append(palmar, skin.palmar, count, 0.0f);
    append(visibility, hand.visibility, count, 1.0f);
    append(contact, hand.contact, count, 0.0f);
  }
  void add_forearm(const SynthFrame& hand, const ForearmMesh& forearm) {
    const size_t count = hand.forearm.size() / 3;
    add(hand.forearm, hand.forearm_normals, forearm.faces);
    occlusion.insert(occlusion.end(), count, 0.0f);
    texture.insert(texture.end(), forearm.rest.begin(), forearm.rest.end());
    nail.insert(nail.end(), count, 0.0f);
    palmar.insert(palmar.end(), count, 0.0f);
    visibility.insert(visibility.end(), count, 1.0f);
    contact.insert(contact.end(), count, 0.0f);
  }
  SynthMeshView view(bool with_visibility, bool with_contact) const {
    return SynthMeshView{&vertices, &normals, &occlusion, &faces, &texture, &nail, &palmar,
                         with_visibility ? &visibility : nullptr,
                         with_contact ? &contact : nullptr};
  }
};

// Key-light visibility of frame k's hands, with every hand and forearm of the frame casting
// shadows (a hand shades the other); forearms are outside every mask and get none.
void cast_shadows(SynthScene& scene, int64_t k) {
  const SynthEffects& effects = scene.config.effects;
  std::vector<SynthFrame*> hands = {&scene.frames[k]};
  if (!scene.left_frames.empty()) hands.push_back(&scene.left_frames[k]);
  JoinedMesh casters;
  for (const SynthFrame* hand : hands) {
    casters.add(hand->vertices, hand->normals, scene.faces);
    casters.add(hand->forearm, hand->forearm_normals, scene.forearm.faces);
  }
  const std::vector<float> visibility =
      light_visibility(casters.vertices, casters.normals, casters.faces, key_light_direction(),
                       effects.light_radius_deg * M_PI / 180.0, effects.light_samples);
  size_t offset = 0;
  for (SynthFrame* hand : hands) {
    const size_t count = hand->vertices.size() / 3;
    hand->visibility.assign(visibility.begin() + offset, visibility.begin() + offset + count);
    offset += count + hand->forearm.size() / 3;
  }
}

json numbers(const double* values, int n) {
  json out = json::array();
  for (int i = 0; i < n; ++i) out.push_back(values[i]);
  return out;
}

int64_t write_interhand_annotations(const SynthScene& scene,
                                    const std::vector<std::array<double, 4>>& boxes,
                                    const std::string& out_dir);

}  // namespace

SynthScene make_synth_scene(const SynthConfig& config) {
  require(config.num_frames > 0 && config.num_cameras > 0, "synth: empty capture");
  require(config.num_sequences >= 1 && config.num_sequences <= config.num_frames,
          "synth: num_sequences must be in [1, num_frames]");
  const bool both = config.hand == CaptureConfig::Hands::both;
  SynthScene scene;
  scene.config = config;
  scene.rig = load_rig_source("builtin");
  scene.axes = rig_axes(scene.rig);
  scene.skin = make_synth_skin(scene.rig, config.seed);
  const SynthEffects& effects = config.effects;
  if (effects.forearm) scene.forearm = make_forearm(scene.rig, scene.axes);
  {
    const torch::Tensor faces = scene.rig.faces.to(torch::kInt64).contiguous();
    scene.faces.assign(faces.data_ptr<int64_t>(), faces.data_ptr<int64_t>() + faces.numel());
  }
  // The poses, LBS and annotations on one thread: LibTorch's reductions split by its thread count,
  // which changed the annotations' last bits between --threads 1 and 2 (2.2e-16 in MANO values).
  std::optional<SingleThreadScope> one_thread(std::in_place);
  const HandMotion right = make_hand_motion(scene.rig, config, config.seed, nullptr);
  std::optional<HandMotion> partner;
  if (both)
    partner = make_hand_motion(scene.rig, config, mix_seed(config.seed, 0x6c656674),  // "left"
                               &right.poses);
  const int64_t n = config.num_frames;
  const torch::Tensor hands_mean = scene.rig.hands_mean.to(torch::kFloat64).contiguous();
  const double* mean = hands_mean.data_ptr<double>();

  SynthRandom drift_random(mix_seed(config.seed, 0x6472696674));  // "drift"
  const double drift_phase[3] = {drift_random.uniform(0, 2 * M_PI),
                                 drift_random.uniform(0, 2 * M_PI),
                                 drift_random.uniform(0, 2 * M_PI)};
  scene.frames.resize(n);
  if (both) scene.left_frames.resize(n);
  for (int64_t k = 0; k < n; ++k) {
    const int sequence = static_cast<int>(k * config.num_sequences / n);
    // The hand's box is centred on kHandCentre plus a slow drift; two hands sit either side of it.
    const double t = 2 * M_PI * static_cast<double>(k) / std::max<int64_t>(n, 20);
    Vec3 drift;
    for (int d = 0; d < 3; ++d) drift[d] = kDrift * std::sin(t * (1 + 0.3 * d) + drift_phase[d]);
    double half_distance = 0;
    if (both) {
      const double gap = kGapMiddle + kGapSwing * std::sin(2 * M_PI * k / kGapPeriod);
      half_distance = 0.25 * (box_extent(right.vertices[k], 2) +
                              box_extent(partner->vertices[k], 2)) + 0.5 * gap;
    }
    SynthFrame& frame = scene.frames[k];
    frame = place_hand(right, k, kHandCentre - Vec3{0, 0, half_distance}, drift, mean);
    frame.seq_name = sequence_name(sequence, effects.gestures ? "gestures" : "rom");
    frame.frame_idx = k * config.frame_step;
    if (!right.gestures.empty()) frame.gesture = right.gestures[k];
    if (both) {
      // Placed where the reflection through z = 0 puts it beside the right hand.
      SynthFrame& left = scene.left_frames[k];
      left = place_hand(*partner, k, {kHandCentre[0], kHandCentre[1], -(kHandCentre[2] + half_distance)},
                        {drift[0], drift[1], -drift[2]}, mean);
      left.seq_name = frame.seq_name;
      left.frame_idx = frame.frame_idx;
      if (!partner->gestures.empty()) left.gesture = partner->gestures[k];
    }
  }
  if (both) annotate_left_hands(load_rig_source("builtin:left"), scene.left_frames);
  one_thread.reset();  // rendering below is per frame and exact on any thread count
  const TissueRig tissue = effects.tissue ? make_tissue_rig(scene.rig, scene.axes) : TissueRig{};
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t k = 0; k < n; ++k) {
    finish_surface(scene, tissue, scene.frames[k]);
    if (both) {
      finish_surface(scene, tissue, scene.left_frames[k]);
      reflect_geometry(scene.left_frames[k]);
    }
    if (effects.cast_shadows) cast_shadows(scene, k);
  }
  // Portrait images show the fingers up: "up" is the rest hand's wrist-to-knuckles direction;
  // azimuth 0 faces the palm.
  scene.cameras =
      make_synth_cameras(config, kHandCentre, scene.skin.palm_long, scene.skin.palm_back);
  scene.responses = effects.camera_response
                        ? make_camera_responses(effects, config.num_cameras, config.seed)
                        : std::vector<CameraResponse>(config.num_cameras);
  return scene;
}

SynthView render_synth_frame(const SynthScene& scene, int frame, int camera) {
  const SynthFrame& f = scene.frames.at(frame);
  const SynthEffects& effects = scene.config.effects;
  const uint64_t noise_seed = mix_seed(scene.config.seed, static_cast<uint64_t>(camera) + 1,
                                       static_cast<uint64_t>(frame) + 1);
  const SkinFlexion flexion = skin_flexion(f.absolute.articulation);
  const bool both = !scene.left_frames.empty();
  SynthMeshView mesh{&f.vertices, &f.normals, &f.occlusion, &scene.faces};
  if (!f.visibility.empty()) mesh.visibility = &f.visibility;
  if (!f.contact.empty()) mesh.contact = &f.contact;
  if (effects.flexion_skin) mesh.flexion = &flexion;
  // With a forearm or a second hand: one mesh of every part (hand, its forearm, the other hand,
  // its forearm). Forearms are textured by their rest points, with no nails, no palm, no
  // occlusion, fully lit by the key light. The left hand takes the right hand's texture points,
  // so its skin is the mirror image of the right one's.
  JoinedMesh joined;
  SkinFlexion left_flexion;
  if (effects.forearm || both) {
    const std::vector<const SynthFrame*> hands =
        both ? std::vector<const SynthFrame*>{&f, &scene.left_frames.at(frame)}
             : std::vector<const SynthFrame*>{&f};
    for (const SynthFrame* hand : hands) {
      if (hand != &f) joined.second_hand_face = static_cast<int64_t>(joined.faces.size() / 3);
      joined.add_hand(*hand, scene.faces, scene.skin);
      if (effects.forearm) joined.add_forearm(*hand, scene.forearm);
    }
    mesh = joined.view(!f.visibility.empty(), !f.contact.empty());
    mesh.flexion = effects.flexion_skin ? &flexion : nullptr;
    if (both && effects.flexion_skin) {
      left_flexion = skin_flexion(scene.left_frames.at(frame).absolute.articulation);
      mesh.second_flexion = &left_flexion;
      mesh.second_hand_face = joined.second_hand_face;
    }
  }
  SynthView view = render_synth_view(scene.skin, mesh, scene.cameras.at(camera).camera,
                                     scene.config.supersample, noise_seed,
                                     !effects.camera_response);
  if (effects.camera_response)
    view.bgr = expose(view.radiance, scene.responses.at(camera), effects,
                      mix_seed(noise_seed, 0x73656e736f72));  // "sensor"
  return view;
}

SynthReport write_synth_capture(const SynthScene& scene, const std::string& out_dir) {
  const auto start = std::chrono::steady_clock::now();
  const SynthConfig& c = scene.config;
  const bool interhand = c.layout == CaptureConfig::Layout::interhand;
  const fs::path root(out_dir);
  // InterHand2.6M keeps split folders; the other layouts have one capture per folder.
  const fs::path images_dir = interhand ? root / "images" / c.split : root / "images";
  const fs::path annotations_dir = root / "annotations" / c.split;
  const fs::path regions_dir = interhand ? root / "regions" / c.split : root / "regions";
  const bool regions = c.effects.region_masks;
  const bool left = c.hand == CaptureConfig::Hands::left;  // written as the mirror image of the right hand (mirror.h)
  const LensDistortion lens = synth_lens_distortion(c.layout);
  auto file_name = [&](const SynthFrame& frame, const SynthCamera& camera) {
    return interhand ? image_file_name(scene, frame, camera) : own_layout_image_name(frame, camera);
  };
  if (interhand) ensure_directory(annotations_dir.string());
  ensure_directory(root.string());
  for (const auto& frame : scene.frames)
    for (const auto& camera : scene.cameras) {
      const fs::path name = file_name(frame, camera);
      ensure_directory((images_dir / name).parent_path().string());
      if (regions) ensure_directory((regions_dir / name).parent_path().string());
    }
  if (regions) write_file_atomic((root / "regions" / "regions.json").string(), regions_legend_json());

  const int64_t num_cameras = static_cast<int64_t>(scene.cameras.size());
  const int64_t num_images = static_cast<int64_t>(scene.frames.size()) * num_cameras;
  std::vector<std::array<double, 4>> boxes(num_images);
  std::vector<int64_t> sizes(num_images, 0);
  std::mutex error_mutex;
  std::string first_error;
  ProgressBar progress("synth " + c.preset, num_images);
  int64_t done = 0;
  // Ctrl-C, SIGTERM or SIGHUP: the images not yet rendered are skipped and the unfinished capture
  // dropped (generate_synth_capture removes its staging folder), instead of leaving it behind.
  const StopSignal stop_signal;
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t i = 0; i < num_images; ++i) {
    if (StopSignal::requested()) continue;  // an OpenMP loop cannot break
    const int frame = static_cast<int>(i / num_cameras), camera = static_cast<int>(i % num_cameras);
    try {
      SynthView view = render_synth_frame(scene, frame, camera);
      if (left) {  // the mirrored world's camera sees the image flipped left to right
        cv::flip(view.bgr, view.bgr, 1);
        if (regions) cv::flip(view.regions, view.regions, 1);
      }
      // The lens distorts what reaches the sensor; region masks stay in the pinhole image, which
      // is what the reader's undistorted images show.
      if (lens.any()) view.bgr = distort_image(view.bgr, written_camera(scene, scene.cameras[camera]), lens);
      std::vector<uint8_t> jpeg;
      cv::imencode(".jpg", view.bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, c.jpeg_quality});
      const SynthFrame& f = scene.frames[frame];
      const SynthCamera& cam = scene.cameras[camera];
      write_file_atomic((images_dir / file_name(f, cam)).string(),
                        std::string(jpeg.begin(), jpeg.end()));
      sizes[i] = static_cast<int64_t>(jpeg.size());
      if (regions) {
        std::vector<uint8_t> png;
        cv::imencode(".png", view.regions, png);
        write_file_atomic((regions_dir / region_file_name(file_name(f, cam))).string(),
                          std::string(png.begin(), png.end()));
        sizes[i] += static_cast<int64_t>(png.size());
      }
      // bbox [x, y, w, h]: the projected mesh's extent, clipped to the image.
      double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
      std::vector<const std::vector<float>*> meshes = {&f.vertices};
      if (!scene.left_frames.empty()) meshes.push_back(&scene.left_frames[frame].vertices);
      for (const std::vector<float>* mesh : meshes)
        for (size_t v = 0; v < mesh->size() / 3; ++v) {
          const auto uv = cam.camera.project_camera(cam.camera.to_camera(
              {(*mesh)[v * 3], (*mesh)[v * 3 + 1], (*mesh)[v * 3 + 2]}));
          x0 = std::min(x0, uv[0]);
          y0 = std::min(y0, uv[1]);
          x1 = std::max(x1, uv[0]);
          y1 = std::max(y1, uv[1]);
        }
      x0 = std::clamp(x0, 0.0, double(cam.camera.width));
      x1 = std::clamp(x1, 0.0, double(cam.camera.width));
      y0 = std::clamp(y0, 0.0, double(cam.camera.height));
      y1 = std::clamp(y1, 0.0, double(cam.camera.height));
      boxes[i] = {x0, y0, x1 - x0, y1 - y0};
      if (left) boxes[i] = mirror_box(boxes[i], cam.camera.width);
    } catch (const std::exception& e) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (first_error.empty()) first_error = e.what();
    }
#pragma omp critical(synth_progress)
    progress.update(++done);
  }
  progress.finish();
  if (StopSignal::requested())
    throw Error("synth: interrupted (SIGINT, SIGTERM or SIGHUP) after " + std::to_string(done) + " of " +
                std::to_string(num_images) + " images, before the capture was complete");
  if (!first_error.empty()) throw Error("synth: " + first_error);
  int64_t bytes = 0;
  if (!interhand) bytes += write_own_layout_annotations(scene, out_dir);
  else bytes += write_interhand_annotations(scene, boxes, out_dir);
  // The resolved generator settings, beside (not inside) the capture's layout.
  SynthConfig resolved = c;
  write_file_atomic((root / kSynthSettingsFile).string(), config_to_json(resolved).dump(2));
  write_csv_atomic((root / "frames.csv").string(), frames_csv(scene, c.held_out_frames));
  for (int64_t s : sizes) bytes += s;
  SynthReport report;
  report.images = num_images;
  report.bytes = bytes;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

namespace {

// data.json (COCO style), camera.json, joint_3d.json and MANO_NeuralAnnot.json under
// annotations/{split}/; returns the bytes written.
int64_t write_interhand_annotations(const SynthScene& scene,
                                    const std::vector<std::array<double, 4>>& boxes,
                                    const std::string& out_dir) {
  const SynthConfig& c = scene.config;
  const fs::path root(out_dir);
  const fs::path annotations_dir = root / "annotations" / c.split;
  const bool left = c.hand == CaptureConfig::Hands::left;
  const int64_t num_cameras = static_cast<int64_t>(scene.cameras.size());
  const int64_t num_images = static_cast<int64_t>(scene.frames.size()) * num_cameras;

  const bool right_present = c.hand != CaptureConfig::Hands::left;
  const bool left_present = c.hand != CaptureConfig::Hands::right;
  json images = json::array(), annotations = json::array();
  json joint_valid = json::array();
  for (int j = 0; j < 42; ++j)  // InterHand order: right hand's 21 joints, then the left's
    joint_valid.push_back(json::array({(j < 21 ? right_present : left_present) ? 1 : 0}));
  for (int64_t i = 0; i < num_images; ++i) {
    const SynthFrame& f = scene.frames[i / num_cameras];
    const SynthCamera& cam = scene.cameras[i % num_cameras];
    images.push_back({{"id", i},
                      {"file_name", image_file_name(scene, f, cam)},
                      {"width", cam.camera.width},
                      {"height", cam.camera.height},
                      {"capture", c.capture},
                      {"subject", 0},
                      {"seq_name", f.seq_name},
                      {"camera", cam.id},
                      {"frame_idx", f.frame_idx}});
    annotations.push_back({{"id", i},
                           {"image_id", i},
                           {"bbox", numbers(boxes[i].data(), 4)},
                           {"joint_valid", joint_valid},
                           {"hand_type", written_hand_type(scene)},
                           {"hand_type_valid", 1}});
  }
  const json data = {{"images", images}, {"annotations", annotations}};

  json campos = json::object(), camrot = json::object(), focal = json::object(),
       princpt = json::object();
  for (const auto& cam : scene.cameras) {
    const InterHandCamera raw =
        left ? mirror_interhand_camera(cam.raw, cam.camera.width) : cam.raw;
    campos[cam.id] = numbers(raw.campos_mm.data(), 3);
    camrot[cam.id] = json::array(
        {numbers(&raw.camrot[0], 3), numbers(&raw.camrot[3], 3), numbers(&raw.camrot[6], 3)});
    focal[cam.id] = numbers(raw.focal.data(), 2);
    princpt[cam.id] = numbers(raw.princpt.data(), 2);
  }
  const std::string capture_key = std::to_string(c.capture);
  const json cameras = {
      {capture_key,
       {{"campos", campos}, {"camrot", camrot}, {"focal", focal}, {"princpt", princpt}}}};

  json joint_frames = json::object(), mano_frames = json::object();
  SynthRandom joint_noise(mix_seed(c.seed, 0x6a6f696e74));  // "joint"
  for (size_t k = 0; k < scene.frames.size(); ++k) {
    // InterHand's 42 joints: the right hand's 21, then the left's; an absent hand's are zero.
    const auto hands = written_hands(scene, k);
    json coords = json::array(), valid = json::array(), mano = json::object();
    for (Handedness side : {Handedness::right, Handedness::left}) {
      const auto& hand = hands[static_cast<int>(side)];
      for (int ih = 0; ih < 21; ++ih) {
        if (hand) {
          const int m = kInterHandFromMano21[ih];
          std::array<double, 3> joint = {hand->joints[m * 3], hand->joints[m * 3 + 1],
                                         hand->joints[m * 3 + 2]};
          if (c.effects.joint_noise_mm > 0)
            for (double& x : joint) x += joint_noise.normal() * c.effects.joint_noise_mm * 1e-3;
          coords.push_back({joint[0] * 1000.0, joint[1] * 1000.0, joint[2] * 1000.0});
        } else {
          coords.push_back({0.0, 0.0, 0.0});
        }
        valid.push_back(json::array({hand.has_value()}));
      }
      mano[hand_name(side)] = hand ? json{{"pose", numbers(hand->pose.data(), 48)},
                                          {"shape", numbers(hand->shape.data(), 10)},
                                          {"trans", numbers(hand->trans.data(), 3)}}
                                   : json(nullptr);
    }
    const std::string key = std::to_string(scene.frames[k].frame_idx);
    joint_frames[key] = {{"world_coord", coords},
                         {"joint_valid", valid},
                         {"hand_type", written_hand_type(scene)},
                         {"hand_type_valid", true}};
    mano_frames[key] = mano;
  }
  const std::string prefix = (annotations_dir / ("InterHand2.6M_" + c.split + "_")).string();
  int64_t bytes = 0;
  for (const auto& [kind, value] : std::vector<std::pair<std::string, json>>{
           {"data", data},
           {"camera", cameras},
           {"joint_3d", json{{capture_key, joint_frames}}},
           {"MANO_NeuralAnnot", json{{capture_key, mano_frames}}}}) {
    const std::string text = value.dump();
    write_file_atomic(prefix + kind + ".json", text);
    bytes += static_cast<int64_t>(text.size());
  }
  return bytes;
}

// What a folder holds, for the message that refuses it ("images/, annotations/, 3 more").
std::string folder_contents(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    names.push_back(entry.path().filename().string() + (entry.is_directory(ec) ? "/" : ""));
  std::sort(names.begin(), names.end());
  std::string text;
  for (size_t i = 0; i < std::min<size_t>(names.size(), 3); ++i)
    text += (i ? ", " : "") + names[i];
  if (names.size() > 3) text += ", " + std::to_string(names.size() - 3) + " more";
  return text;
}

}  // namespace

SynthReport generate_synth_capture(const SynthConfig& config, const std::string& out_dir,
                                   bool overwrite) {
  const auto start = std::chrono::steady_clock::now();
  check_synth_size(config);
  check_synth_memory(config, omp_get_max_threads(), available_memory_bytes());
  const fs::path out = fs::absolute(out_dir).lexically_normal();
  std::error_code ec;
  // A file is named as one before any folder check: --overwrite replaces folders only.
  if (fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw Error(out_dir + ": is a file, not a folder; choose another --out (--overwrite replaces "
                          "only a folder)");
  const bool occupied = fs::exists(out, ec) && !fs::is_empty(out, ec);
  if (occupied && !overwrite)
    throw Error(out_dir + ": not empty (" + folder_contents(out) +
                "); choose another --out, or replace it with --overwrite");
  // Written beside the old folder and swapped in only when complete: a failure or an interrupt
  // leaves whatever was there as it was (only the staging folder of a killed run stays behind).
  const std::string suffix = "." + std::to_string(::getpid());
  const fs::path staging = out.string() + ".synth-new" + suffix;
  const fs::path replaced = out.string() + ".synth-old" + suffix;
  fs::remove_all(staging, ec);
  SynthReport report;
  try {
    const SynthScene scene = make_synth_scene(config);
    report = write_synth_capture(scene, staging.string());
  } catch (...) {
    fs::remove_all(staging, ec);
    throw;
  }
  if (fs::exists(out, ec)) fs::rename(out, replaced);
  fs::rename(staging, out);
  fs::remove_all(replaced, ec);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  spdlog::info(
      "synth {}: {} cameras x {} frames = {} images ({}x{} portrait), {:.1f} MB in {:.1f} s -> {}",
      config.preset, config.num_cameras, config.num_frames, report.images, config.width,
      config.height, report.bytes / 1e6, report.seconds, out_dir);
  return report;
}

}  // namespace handscs
