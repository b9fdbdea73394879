// A speed-accuracy sweep: which run config to start from, which settings every point shares, which
// to vary (named points, each a list of --set overrides), which training budgets to run each point
// at, how many held-out images to score, and the rasterizer-only timing grid. Read from a JSON file
// (configs/sweeps/*.json); docs/BENCHMARKS.md explains the fields.
#pragma once

#include <string>
#include <vector>

namespace handscs {

struct SweepPoint {
  std::string name;               // row label and run folder name ([A-Za-z0-9_.-]+)
  std::vector<std::string> set;   // handscs-train --set overrides: the sweep's shared ones, then the point's
  int threads = 0;                // 0 = the sweep's threads
  std::vector<int> budgets;       // empty = the sweep's budgets
};

struct RasterGrid {
  std::vector<int> gaussians;     // N values timed by handscs-bench-raster (empty = skip)
  std::vector<int> threads = {1, 2};
  int repeats = 10;               // timed repeats per cell (median reported)
};

struct SweepConfig {
  std::string path;               // the sweep file (errors and relative paths)
  std::string run_config;         // handscs-train config every point starts from (absolute)
  std::string capture_preset = "bench";  // handscs-synth preset made when the capture is missing
  std::vector<int> budgets;       // training iterations; each (point, budget) is its own run
  int eval_images = 0;            // held-out images scored per run, evenly spaced (0 = all)
  int threads = 2;                // training and evaluation threads unless a point says otherwise
  std::vector<SweepPoint> points;
  RasterGrid raster;
};

// Reads and checks a sweep file; errors name the file and the key.
SweepConfig load_sweep_config(const std::string& path);

}  // namespace handscs
