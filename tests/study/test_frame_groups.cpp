// tools/study/frame_groups.py: held-out scores split into gestures training saw and gestures it never
// saw, against means computed here from the same made-up per-image scores; failed images and
// missing metrics are left out and counted; an image of another capture is an error naming it.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/csv_table.h"
#include "data/data_test_helpers.h"

namespace {

std::string python() {
  for (const char* candidate : {"python3", "/usr/bin/python3"})
    if (std::system((std::string(candidate) + " -c 'import csv' > /dev/null 2>&1").c_str()) == 0)
      return candidate;
  return "";
}

}  // namespace

TEST_CASE("frame_groups.py: held-out means per gesture kind equal the means computed here") {
  const std::string py = python();
  if (py.empty()) {
    WARN("no python3: tools/study/frame_groups.py not tested");
    return;
  }
  const std::string dir = data_test::fresh_dir("frame_groups");
  // Poses 0-5 train, 6-11 held out; held-out gestures alternate seen / unseen.
  std::string frames = "seq_name,frame_idx,held_out,gesture,gesture_in_training\n";
  for (int k = 0; k < 12; ++k)
    frames += "0000_synth_gestures," + std::to_string(6 * k) + "," + (k >= 6 ? "1" : "0") + "," +
              (k % 2 ? "rock,0" : "fist,1") + "\n";
  data_test::write_text(dir + "/frames.csv", frames);
  // Two cameras per held-out pose; made-up scores that depend on pose and camera.
  std::string images = "name,status,psnr,ssim,lpips\n";
  double sum[2][3] = {}, count[2][3] = {};
  for (int k = 6; k < 12; ++k)
    for (int cam = 0; cam < 2; ++cam) {
      const double psnr = 20 + k + 0.25 * cam, ssim = 0.9 + 0.001 * k, lpips = 0.1 - 0.002 * k + 0.01 * cam;
      const bool failed = k == 9 && cam == 1;  // left out of every metric
      const bool no_lpips = k == 10 && cam == 0;  // left out of LPIPS only
      images += "Capture0/0000_synth_gestures/cam40000" + std::to_string(cam) + "/image" +
                std::to_string(6 * k) + ".jpg," + (failed ? "failed,,," : "ok," + std::to_string(psnr) + "," +
                std::to_string(ssim) + "," + (no_lpips ? "" : std::to_string(lpips))) + "\n";
      if (failed) continue;
      const int group = k % 2;  // 0 seen, 1 unseen
      const double values[3] = {psnr, ssim, lpips};
      for (int m = 0; m < 3; ++m) {
        if (m == 2 && no_lpips) continue;
        sum[group][m] += values[m];
        count[group][m] += 1;
      }
    }
  data_test::write_text(dir + "/run/eval/per_image.csv", images);
  const std::string script = std::string(HANDSCS_SOURCE_DIR) + "/tools/study/frame_groups.py";
  const std::string command = py + " '" + script + "' '" + dir + "/frames.csv' '" + dir + "/run' --csv '" +
                              dir + "/out.csv' > '" + dir + "/log' 2>&1";
  REQUIRE(std::system(command.c_str()) == 0);
  const handscs::CsvTable out = handscs::read_csv(dir + "/out.csv");
  REQUIRE(out.rows.size() == 1);
  const auto& row = out.rows[0];
  REQUIRE(row.size() == 10);
  CHECK(row[0] == "run");
  for (int group = 0; group < 2; ++group) {
    INFO((group ? "unseen" : "seen"));
    CHECK(std::stoi(row[1 + 4 * group]) == count[group][0]);
    for (int m = 0; m < 3; ++m) CHECK(std::stod(row[2 + 4 * group + m]) == Approx(sum[group][m] / count[group][m]).epsilon(1e-9));
  }
  CHECK(row[9] == "4");  // the failed image's three metrics and one missing LPIPS

  // An image that is not a held-out frame of frames.csv: refused, naming it.
  data_test::write_text(dir + "/bad/eval/per_image.csv",
                        "name,status,psnr,ssim,lpips\nCapture0/0000_synth_gestures/cam400000/image6.jpg,ok,1,1,1\n");
  const std::string bad = py + " '" + script + "' '" + dir + "/frames.csv' '" + dir + "/bad' > '" + dir +
                          "/bad_log' 2>&1";
  CHECK(std::system(bad.c_str()) != 0);
  CHECK(handscs::read_file(dir + "/bad_log").find("image6.jpg is not a held-out frame") != std::string::npos);
}
