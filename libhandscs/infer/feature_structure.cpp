#include "infer/feature_structure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>

#include <sys/wait.h>

#include <CLI/CLI.hpp>
#include <c10/core/InferenceMode.h>
#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>
#include <torch/types.h>

#include "core/atomic_file.h"
#include "core/cli.h"
#include "core/config.h"
#include "core/csv_table.h"
#include "core/error.h"
#include "core/float_vector.h"
#include "core/installed_paths.h"
#include "data/capture.h"
#include "data/mesh_mask.h"
#include "infer/feature_grid.h"
#include "infer/feature_metrics.h"
#include "infer/feature_pca.h"
#include "infer/feature_sets.h"
#include "infer/pose_source.h"
#include "io/png.h"
#include "metrics/image_tensor.h"
#include "render/camera_json.h"
#include "render/orbit.h"
#include "run/avatar_state_io.h"
#include "run/checkpoint.h"

namespace handscs {

namespace {

// Debian's Python, which has python3-sklearn and python3-matplotlib (a PATH python may lack them).
const char kPython[] = "/usr/bin/python3";
// Pixels kept around the hands in the grid's cells: room for the Gaussians' soft edges.
constexpr int kCropMargin = 12;

struct PoseSelection {
  std::vector<PoseFrame> frames;
  std::optional<Camera> camera;  // the capture camera chosen, when the poses come from the capture
  std::string camera_source;
};

std::string pose_name(int pose_index) {
  char name[32];
  std::snprintf(name, sizeof(name), "pose_%03d", pose_index);
  return name;
}

// `count` held-out poses evenly spaced over the capture's held-out poses (first and last included),
// and the capture camera in which the first of them covers the most pixels (the posed rig mesh's
// mask, so the choice depends on the capture only, not on the avatar: runs compared see one view).
PoseSelection held_out_poses(const RunConfig& config, int count) {
  require(!config.data.root.empty(), "the checkpoint's config names no capture (data.root): give --poses POSES");
  Capture capture = Capture::open(config.data, "", "data");
  const auto& test = capture.test();
  require(!test.empty(), config.data.root + ": the capture has no held-out frames: give --poses POSES");
  std::set<int> ids;
  for (const auto& f : test) ids.insert(f.pose_index);
  const std::vector<int> pose_ids(ids.begin(), ids.end());
  const int n = static_cast<int>(pose_ids.size());
  const int take = std::min(count, n);
  PoseSelection s;
  std::vector<int> chosen;
  for (int i = 0; i < take; ++i)
    chosen.push_back(pose_ids[take == 1 ? 0 : static_cast<size_t>(std::lround(double(i) * (n - 1) / (take - 1)))]);
  for (int id : chosen) {
    const auto it = std::find_if(test.begin(), test.end(), [&](const FrameInfo& f) { return f.pose_index == id; });
    PoseFrame frame;
    frame.pose = it->pose;
    frame.shape = it->shape;
    frame.trans = it->trans;
    frame.name = pose_name(id);
    s.frames.push_back(frame);
  }
  const auto& vertices = capture.posed_vertices(chosen[0]);
  const auto& faces = capture.faces();
  int64_t best = -1;
  for (const auto& f : test) {
    if (f.pose_index != chosen[0]) continue;
    const cv::Mat mask = mesh_mask(vertices.data(), static_cast<int64_t>(vertices.size() / 3), faces.data(),
                                   static_cast<int64_t>(faces.size() / 3), f.camera);
    const int64_t area = cv::countNonZero(mask);
    if (area > best) {
      best = area;
      s.camera = f.camera;
      s.camera_source = "capture camera " + f.camera_id + " (the largest view of " + pose_name(chosen[0]) + ")";
    }
  }
  spdlog::info("poses: {} of the capture's {} held-out poses; {}", take, n, s.camera_source);
  return s;
}

// View 0 of handscs-render's orbit around a posed hand (infer/avatar_render.cpp): centre and long
// axis (wrist -> middle fingertip, MANO21 joints 0 and 18) from the pose.
Camera orbit_view(Avatar& avatar, const PoseFrame& f) {
  const auto state = avatar.pose(float_vector(f.pose), float_vector(f.shape), float_vector(f.trans));
  const auto joints = state.lbs.joints[0].to(torch::kFloat64);
  const auto means = state.posed.means.to(torch::kFloat64);
  const auto centre = means.mean(0);
  const auto axis = joints[18] - joints[0];
  OrbitSpec spec;
  spec.count = 1;
  return orbit_cameras({centre[0].item<double>(), centre[1].item<double>(), centre[2].item<double>()},
                       {axis[0].item<double>(), axis[1].item<double>(), axis[2].item<double>()},
                       (means.amax(0) - means.amin(0)).norm().item<double>(), spec)[0];
}

json pose_json(const PoseFrame& f) {
  return {{"name", f.name},
          {"pose", std::vector<float>(f.pose.begin(), f.pose.end())},
          {"shape", std::vector<float>(f.shape.begin(), f.shape.end())},
          {"trans", std::vector<float>(f.trans.begin(), f.trans.end())}};
}

FeatureSet score_set(const std::string& name) {
  for (FeatureSet set : kFeatureSets)
    if (name == feature_set_name(set)) return set;
  throw Error("no feature set " + name + " (programming error)");
}

// Column names of each block, as features.csv writes them.
std::vector<std::string> column_series(const std::string& prefix, int64_t count) {
  std::vector<std::string> names;
  for (int64_t i = 0; i < count; ++i) names.push_back(prefix + std::to_string(i));
  return names;
}

// Column names of each feature set, keyed like GaussianFeatures::get.
struct Columns {
  std::map<FeatureSet, std::vector<std::string>> by_set;
  const std::vector<std::string>& get(FeatureSet set) const { return by_set.at(set); }
};

Columns column_names(const GaussianFeatures& f, bool scs) {
  const int64_t d = f.embedding.size(1) / 2;
  std::vector<std::string> embedding = column_series("eg", d);
  const auto ea = column_series("ea", d);
  embedding.insert(embedding.end(), ea.begin(), ea.end());
  const std::vector<std::string> transform = column_series("t", 12);
  const std::vector<std::string> descriptor = column_series("p", f.descriptor.size(1));
  const auto split = descriptor.begin() + f.descriptor_static.size(1);
  std::vector<std::string> decoder_input;
  if (scs) decoder_input = descriptor;
  decoder_input.insert(decoder_input.end(), embedding.begin(), embedding.end());
  decoder_input.insert(decoder_input.end(), transform.begin(), transform.end());
  Columns c;
  c.by_set[FeatureSet::position] = {"x", "y", "z"};
  c.by_set[FeatureSet::embedding] = embedding;
  c.by_set[FeatureSet::transform] = transform;
  c.by_set[FeatureSet::descriptor] = descriptor;
  c.by_set[FeatureSet::descriptor_static] = {descriptor.begin(), split};
  c.by_set[FeatureSet::descriptor_virtual] = {split, descriptor.end()};
  c.by_set[FeatureSet::decoder_input] = decoder_input;
  return c;
}

// features.csv: pose, gaussian, label, then position, embedding, transform and descriptor columns
// (the decoder input is made of these; features.json says which).
void write_features_csv(const std::string& path, const std::vector<PoseFrame>& poses,
                        const std::vector<GaussianFeatures>& features, const Columns& columns) {
  std::string text = "pose,gaussian,label";
  for (FeatureSet set : {FeatureSet::position, FeatureSet::embedding, FeatureSet::transform, FeatureSet::descriptor})
    for (const auto& name : columns.get(set)) text += "," + name;
  text += "\n";
  char cell[32];
  for (size_t p = 0; p < poses.size(); ++p) {
    const auto& f = features[p];
    const auto table = torch::cat({f.position, f.embedding, f.transform, f.descriptor}, 1).contiguous();
    const double* v = table.data_ptr<double>();
    const int64_t* labels = f.labels.data_ptr<int64_t>();
    const int64_t cols = table.size(1);
    for (int64_t i = 0; i < table.size(0); ++i) {
      text += poses[p].name + "," + std::to_string(i) + "," + std::to_string(labels[i]);
      for (int64_t j = 0; j < cols; ++j) {
        std::snprintf(cell, sizeof(cell), ",%.9g", v[i * cols + j]);  // 9 digits: float32 values exactly
        text += cell;
      }
      text += "\n";
    }
  }
  write_file_atomic(path, text);
}



std::string percent(double share) {
  char text[16];
  std::snprintf(text, sizeof(text), "%.0f%%", 100 * share);
  return text;
}

// Fig. 1(b): the avatar's own render, then its Gaussians coloured by each representation's first
// three principal components (rows), in each pose (columns), cropped together to the hands, written
// to `path`. Returns each representation's column count and variance shares of the components.
json write_pca_grid(const std::string& path, const std::vector<GaussianFeatures>& features,
                    const std::vector<std::string>& pose_names, const Camera& camera, const std::string& corner,
                    bool scs, double colour_percentile) {
  const std::vector<std::pair<FeatureSet, std::string>> rows = {
      {FeatureSet::embedding, "embedding [e_g, e_a]"},
      {FeatureSet::transform, "LBS transform vec(T)"},
      {FeatureSet::descriptor, scs ? "SCS coordinate P" : "P (not a decoder\ninput without SCS)"}};
  RasterSettings settings;  // black background
  LabelledGrid grid;
  grid.corner = corner;
  grid.column_labels = pose_names;
  grid.row_labels.push_back("render");
  std::vector<std::vector<RasterOutput>> renders(1);
  for (const auto& f : features) renders[0].push_back(render_posed(f.posed, camera, settings));
  json pca = json::object();
  for (const auto& [set, title] : rows) {
    std::vector<torch::Tensor> pooled;
    for (const auto& f : features) pooled.push_back(f.get(set));
    const auto all = torch::cat(pooled, 0);
    if (all.size(1) == 0) continue;  // e.g. a model without embeddings
    const FeatureColouring colouring = fit_feature_colouring(all, colour_percentile);
    const auto explained = colouring.pca.explained;
    pca[feature_set_name(set)] = {
        {"dims", all.size(1)},
        {"explained", std::vector<double>(explained.data_ptr<double>(), explained.data_ptr<double>() + explained.numel())}};
    grid.row_labels.push_back(title + "\n" + std::to_string(all.size(1)) + "-D, PCs 1-3: " +
                              percent(explained.sum().item<double>()) + " of var.");
    renders.emplace_back();
    for (const auto& f : features) {
      PosedGaussians coloured = f.posed;
      coloured.colors = colouring.colours(f.get(set)).to(f.posed.means.dtype());
      renders.back().push_back(render_posed(coloured, camera, settings));
    }
  }
  // Only the colours differ between rows: the render row's coverage is every row's.
  std::vector<torch::Tensor> alphas;
  for (const auto& r : renders[0]) alphas.push_back(r.alpha);
  const PixelRect box = coverage_box(alphas, kCropMargin);
  for (const auto& row : renders) {
    grid.cells.emplace_back();
    for (const auto& r : row)
      grid.cells.back().push_back(
          rgb_tensor_to_mat(r.rgb.clamp(0, 1))(cv::Rect(box.x0, box.y0, box.width(), box.height())).clone());
  }
  write_png(path, compose_grid(grid));
  return pca;
}

// Runs `argv` through the shell (each word quoted); returns its exit status.
int run_script(const std::vector<std::string>& argv) {
  std::string command;
  for (const auto& word : argv) command += (command.empty() ? "" : " ") + shell_quote(word);
  spdlog::info("running {}", command);
  const int status = std::system(command.c_str());
  return status == -1 ? -1 : WEXITSTATUS(status);
}

}  // namespace

void add_feature_structure_options(CLI::App& app, FeatureStructureOptions& o) {
  app.add_option("--checkpoint", o.checkpoint, "trained avatar: checkpoint file, or a run folder (its newest checkpoint)")
      ->required();
  app.add_option("--out", o.out_dir,
                 "output folder: pca_grid.png (rows: render, embedding, vec(T), P; columns: poses), "
                 "features.csv/.json, metrics.csv/.json, metrics_summary.csv, poses.json, camera.json, "
                 "tsne_decoder_input.png")
      ->required();
  app.add_option("--poses", o.poses,
                 "POSES file (as handscs-render's; e.g. another run's poses.json, to compare runs on the same "
                 "poses); default: --num-poses held-out poses of the run's capture, evenly spaced");
  app.add_option("--num-poses", o.num_poses, "poses taken from the capture without --poses")
      ->check(CLI::Range(1, 100));
  app.add_option("--camera", o.camera,
                 "camera JSON of the grid's view (e.g. another run's camera.json); default: the capture camera "
                 "in which the first pose's hand is largest, or an orbit view when POSES has no cameras");
  app.add_option("--label", o.label, "the run's name in files and plots (default: SCS or no SCS, from its config)");
  app.add_option("--knn", o.knn_k, "k of the leave-one-out k-NN accuracy")->check(CLI::Range(1, 1000));
  app.add_option("--colour-percentile", o.colour_percentile,
                 "each principal component's colour spans this percentile to 100 minus it (0 = min-max)")
      ->check(CLI::Range(0.0, 49.0));
  app.add_flag("!--no-plot", o.plot,
               "do not run plot_features.py (t-SNE of this run, scikit-learn check of the metrics)");
}

void refuse_out_holding_training_files(const std::string& out_dir) {
  const std::filesystem::path out(out_dir);
  const std::string advice = "; choose another --out, e.g. " + (out / "features").string();
  std::error_code ec;
  if (std::filesystem::exists(out / "config.json", ec) || !list_checkpoints(out_dir).empty())
    throw Error("--out " + out_dir + " holds a training run (config.json, checkpoints/): its metrics.csv, " +
                "the training log, would be replaced by the k-NN table" + advice);
  const std::filesystem::path metrics = out / "metrics.csv";
  std::string header;
  if (std::filesystem::is_regular_file(metrics, ec)) std::getline(std::ifstream(metrics), header);
  // The header's start names the file well enough (a training log's names some 30 columns).
  constexpr size_t kShownHeader = 60;
  const std::string shown = header.size() > kShownHeader ? header.substr(0, kShownHeader) + "..." : header;
  if (!header.empty() && header != kFeatureScoresPerPoseHeader)
    throw Error(metrics.string() + " was not written by handscs-features (its header: \"" + shown +
                "\") and would be replaced" + advice);
}

FeatureStructureResult run_feature_structure(const FeatureStructureOptions& options) {
  require(!options.out_dir.empty(), "--out DIR is required");
  require(options.num_poses >= 1, "--num-poses must be at least 1");
  refuse_out_holding_training_files(options.out_dir);
  // A --camera mistake is reported before the checkpoint and capture are read.
  const std::optional<Camera> given_camera =
      options.camera.empty() ? std::nullopt : std::optional<Camera>(read_camera_json(options.camera));
  TrainedAvatar trained = open_trained_avatar(options.checkpoint);
  Avatar& avatar = trained.avatar;
  const bool scs = avatar.config().scs.enabled;
  FeatureStructureResult result;
  result.label = options.label.empty() ? (scs ? "SCS" : "no SCS") : options.label;

  PoseSelection selection;
  if (options.poses.empty()) {
    selection = held_out_poses(trained.config, options.num_poses);
  } else {
    selection.frames = read_pose_source(options.poses);
    if (selection.frames.front().camera) {
      selection.camera = selection.frames.front().camera;
      selection.camera_source = "the camera of " + selection.frames.front().name + " in " + options.poses;
    }
  }
  c10::InferenceMode guard;
  Camera camera;
  if (given_camera) {
    camera = *given_camera;
    selection.camera_source = options.camera;
  } else if (selection.camera) {
    camera = *selection.camera;
  } else {
    camera = orbit_view(avatar, selection.frames.front());
    selection.camera_source = "orbit view 0 around " + selection.frames.front().name;
  }

  const auto& poses = selection.frames;
  std::vector<GaussianFeatures> features;
  for (const auto& f : poses) {
    features.push_back(gaussian_features(avatar, float_vector(f.pose), float_vector(f.shape), float_vector(f.trans)));
    result.poses.push_back(f.name);
  }
  const auto& labels = features.front().labels;
  result.gaussians = labels.size(0);
  result.majority_share = torch::bincount(labels).max().item<double>() / double(result.gaussians);
  const Columns columns = column_names(features.front(), scs);
  ensure_directory(options.out_dir);
  const std::string out = options.out_dir + "/";

  // Fig. 1(b): one colouring per representation, fitted on the poses pooled.
  result.grid_png = out + "pca_grid.png";
  const json pca_json = write_pca_grid(result.grid_png, features, result.poses, camera,
                                       result.label + "\n" + std::to_string(result.gaussians) + " Gaussians",
                                       scs, options.colour_percentile);

  // Fig. 7 made a number: per feature set, standardised once on the poses pooled.
  result.scores = score_feature_sets(features, options.knn_k);
  json sets_json = json::object();
  for (const auto& score : result.scores) {
    sets_json[score.set] = feature_score_json(score);
    sets_json[score.set]["columns"] = columns.get(score_set(score.set));
  }
  const auto counts = torch::bincount(labels, {}, 16);
  const json info = {{"label", result.label},
                     {"checkpoint", trained.path},
                     {"scs_enabled", scs},
                     {"gaussians", result.gaussians},
                     {"poses", result.poses},
                     {"camera", selection.camera_source},
                     {"label_names", phalange_names()},
                     {"label_counts", std::vector<int64_t>(counts.data_ptr<int64_t>(), counts.data_ptr<int64_t>() + 16)},
                     {"majority_share", result.majority_share}};
  json metrics = info;
  metrics["k"] = options.knn_k;
  metrics["space"] = "each feature set's columns standardised (mean 0, population std 1) over the poses pooled; "
                     "Euclidean distance";
  metrics["knn_transfer"] = "mean over ordered pose pairs (a, b), a != b, of the k-NN accuracy of b's Gaussians "
                            "among a's";
  metrics["knn_balanced_accuracy"] = "mean over the labels of the share of their Gaussians labelled right";
  metrics["std"] = "sample standard deviation over the poses (n - 1)";
  metrics["sets"] = sets_json;
  metrics["pca"] = pca_json;
  write_file_atomic(out + "metrics.json", metrics.dump(2) + "\n");
  write_file_atomic(out + "metrics.csv", feature_scores_per_pose_csv(result.label, result.poses, result.scores));
  write_file_atomic(out + "metrics_summary.csv", feature_scores_summary_csv(result.label, result.scores,
                                                                            result.gaussians, result.majority_share));

  json meta = info;
  json sets_meta = json::object();
  for (FeatureSet set : kFeatureSets) sets_meta[feature_set_name(set)] = columns.get(set);
  meta["sets"] = sets_meta;
  meta["knn_k"] = options.knn_k;
  write_file_atomic(out + "features.json", meta.dump(2) + "\n");
  write_features_csv(out + "features.csv", poses, features, columns);
  json poses_json = json::array();
  for (const auto& f : poses) poses_json.push_back(pose_json(f));
  write_file_atomic(out + "poses.json", json{{"poses", poses_json}}.dump(2) + "\n");
  write_camera_json(out + "camera.json", camera);

  // Without the plot script the features and metrics above are complete: the plot and the check are
  // skipped with a warning, as when Python or scikit-learn is missing.
  std::string script;
  try {
    script = installed_script("plot_features.py");
  } catch (const Error& e) {
    if (options.plot) spdlog::warn("no t-SNE plot or scikit-learn check: {}", e.what());
    return result;
  }
  result.plot_command = std::string(kPython) + " " + shell_quote(script) + " tsne --out tsne_scs_vs_noscs.png " +
                        shell_quote(result.label + "=" + options.out_dir) + " 'other label=OTHER_OUT'";
  if (options.plot) {
    const int checked = run_script({kPython, script, "check", options.out_dir});
    if (checked != 0)
      spdlog::warn("the scikit-learn check of {}metrics.json did not pass (exit status {}; see above)", out, checked);
    const int drawn = run_script({kPython, script, "tsne", "--out", out + "tsne_decoder_input.png",
                                  result.label + "=" + options.out_dir});
    if (drawn != 0) spdlog::warn("t-SNE plot not drawn (exit status {}; see above)", drawn);
  }
  return result;
}

std::string format_feature_scores(const FeatureStructureResult& r) {
  char line[512];
  std::snprintf(line, sizeof(line), "%s: %lld Gaussians, %zu poses; the largest label holds %.1f%%\n",
                r.label.c_str(), static_cast<long long>(r.gaussians), r.poses.size(), 100 * r.majority_share);
  return line + format_feature_score_table(r.scores);
}

}  // namespace handscs
