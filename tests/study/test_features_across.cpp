// tools/study/features_across.py, which reads Fig. 7's claim over training runs: its two column unions
// (with and without P) are scored against a k-NN vote and silhouettes worked out here on four
// Gaussians whose geometry is chosen by hand (differing by run and pose, so each run's and pose's
// own features must be read), the groups' mean and sample standard deviation against the made-up
// summaries written below, and the pairs' gap, control and share by hand.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/atomic_file.h"
#include "core/csv_table.h"
#include "test_support.h"

namespace {

// Four Gaussians, labels 0, 0, 1, 1, in two poses. P's two columns separate the labels in both.
// The embedding's one column is kMixed (each Gaussian next to one of the other label) or kP
// (next to its own label), chosen per run and pose. The transform's column is constant
// (standardised to zero). Every varying column holds the same values over the two poses pooled, so
// standardisation scales them alike and distances keep their raw proportions.
using Column = std::array<double, 4>;
constexpr Column kP = {0, 0.1, 10, 10.1};
constexpr Column kMixed = {0, 10, 0.1, 10.1};
constexpr std::array<int, 4> kLabel = {0, 0, 1, 1};

// Rousseeuw's silhouette of the four points, brute force: a = distance to the one other point of
// its label, b = mean distance to the two of the other label.
double silhouette(const Column& e, bool with_p) {
  const auto distance = [&](int i, int j) {
    const double dp = kP[i] - kP[j], de = e[i] - e[j];
    return std::sqrt((with_p ? 2 * dp * dp : 0) + de * de);
  };
  double total = 0;
  for (int i = 0; i < 4; ++i) {
    double a = 0, b = 0;
    for (int j = 0; j < 4; ++j) {
      if (j == i) continue;
      if (kLabel[j] == kLabel[i])
        a += distance(i, j);
      else
        b += distance(i, j) / 2;
    }
    total += (b - a) / std::max(a, b);
  }
  return total / 4;
}

// One handscs-features output folder (k = 1): features.json/.csv with embedding columns e_a and e_b
// in poses a and b, and a summary whose decoder input scores `decoder_knn` (the other figures are
// arbitrary but distinct).
void write_run(const std::string& dir, const std::string& label, double decoder_knn, const Column& e_a,
               const Column& e_b) {
  handscs::ensure_directory(dir);
  handscs::write_file_atomic(dir + "/features.json",
                             R"({"label": ")" + label + R"(", "knn_k": 1, "poses": ["a", "b"], "sets": {"descriptor": ["p0", "p1"],)"
                             R"( "embedding": ["e0"], "transform": ["t0"], "decoder_input": ["p0", "p1", "e0", "t0"]}})");
  std::string csv = "pose,gaussian,label,p0,p1,e0,t0\n";
  for (const auto& [pose, e] : {std::pair<std::string, Column>{"a", e_a}, {"b", e_b}})
    for (int g = 0; g < 4; ++g)
      csv += pose + "," + std::to_string(g) + "," + std::to_string(kLabel[g]) + "," + std::to_string(kP[g]) + "," +
             std::to_string(kP[g]) + "," + std::to_string(e[g]) + ",0.5\n";
  handscs::write_file_atomic(dir + "/features.csv", csv);
  handscs::write_file_atomic(dir + "/metrics_summary.csv",
                             "run,set,dims,knn_mean,knn_sd,knn_balanced_mean,knn_balanced_sd,silhouette_mean,silhouette_sd,"
                             "knn_transfer,knn_transfer_balanced,gaussians,majority_share\n" +
                             label + ",decoder_input,4," + std::to_string(decoder_knn) + ",0,0.6,0,0.1,0,0.7,0.5,4,0.5\n");
}

std::map<std::string, std::vector<std::string>> rows_by_key(const handscs::CsvTable& table, int key_columns) {
  std::map<std::string, std::vector<std::string>> out;
  for (const auto& row : table.rows) {
    std::string key;
    for (int c = 0; c < key_columns; ++c) key += (c ? "|" : "") + row[c];
    out[key] = row;
  }
  return out;
}

}  // namespace

TEST_CASE("features_across.py: unions, group means and pairs equal the values worked out here") {
  const std::string dir = handscs_test::scratch_path("handscs_test_features_across", std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  // scs0's embedding mixes the labels in both poses, scs1's separates them in both; the plain runs'
  // mixes them in pose a and separates them in pose b.
  write_run(dir + "/scs0", "scs0", 0.9, kMixed, kMixed);
  write_run(dir + "/scs1", "scs1", 0.8, kP, kP);
  write_run(dir + "/plain0", "plain0", 0.7, kMixed, kP);
  write_run(dir + "/plain1", "plain1", 0.75, kMixed, kP);
  const std::string script = "/usr/bin/python3 '" + handscs_test::kSource + "/tools/study/features_across.py'";
  const std::string command = script + " --pair scs=plain --out '" + dir + "/across' 'scs=" + dir + "/scs0," +
                              dir + "/scs1' 'plain=" + dir + "/plain0," + dir + "/plain1' > '" + dir + "/log' 2>&1";
  REQUIRE(std::system(command.c_str()) == 0);

  const auto rows = rows_by_key(handscs::read_csv(dir + "/across.csv"), 3);
  const auto value = [&](const std::string& key, int column) {
    INFO(key);
    REQUIRE(rows.count(key) == 1);
    return std::stod(rows.at(key)[column]);
  };
  // columns: group, set, metric, run0, run1, mean, sd
  // With P, each Gaussian's nearest neighbour is the other of its label; without, with the mixed
  // embedding, one of the other label, and with the separating one, its own.
  CHECK(value("scs|with_p|knn", 5) == Approx(1).margin(1e-6));
  CHECK(value("scs|with_p|balanced", 5) == Approx(1).margin(1e-6));
  CHECK(value("scs|without_p|knn", 3) == Approx(0).margin(1e-6));
  CHECK(value("scs|without_p|knn", 4) == Approx(1).margin(1e-6));
  CHECK(value("scs|without_p|knn", 6) == Approx(std::sqrt(0.5)).margin(1e-6));
  CHECK(value("plain|without_p|knn", 3) == Approx(0.5).margin(1e-6));  // the mean of its poses: 0 and 1
  CHECK(value("plain|without_p|balanced", 5) == Approx(0.5).margin(1e-6));
  CHECK(value("plain|with_p|knn", 5) == Approx(1).margin(1e-6));
  CHECK(value("scs|with_p|silhouette", 3) == Approx(silhouette(kMixed, true)).margin(1e-5));
  CHECK(value("scs|with_p|silhouette", 4) == Approx(silhouette(kP, true)).margin(1e-5));
  CHECK(value("plain|without_p|silhouette", 4) ==
        Approx((silhouette(kMixed, false) + silhouette(kP, false)) / 2).margin(1e-5));
  // The worked values: (-0.49 - 0.5 - 0.5 - 0.49) / 4 and (0.99005 + 0.98995 + 0.98995 + 0.99005) / 4.
  CHECK(silhouette(kMixed, false) == Approx(-0.495).margin(1e-12));
  CHECK(silhouette(kP, false) == Approx(0.99).margin(1e-5));
  // The summaries' decoder input over the runs: 0.9 and 0.8, 0.7 and 0.75.
  CHECK(value("scs|decoder_input|knn", 3) == Approx(0.9).margin(1e-6));
  CHECK(value("scs|decoder_input|knn", 5) == Approx(0.85).margin(1e-6));
  CHECK(value("scs|decoder_input|knn", 6) == Approx(std::sqrt(0.005)).margin(1e-6));
  CHECK(value("plain|decoder_input|knn", 5) == Approx(0.725).margin(1e-6));
  CHECK(value("plain|decoder_input|across", 6) == Approx(0).margin(1e-6));

  // Pairs: gap = scs's decoder input - plain's; control = plain's with_p (1) - scs's decoder input;
  // without_p = scs's without_p (0, then 1) - plain's decoder input.
  const auto pairs = rows_by_key(handscs::read_csv(dir + "/across_pairs.csv"), 3);
  const auto pair = [&](const std::string& run, int column) { return std::stod(pairs.at("scs|plain|" + run)[column]); };
  REQUIRE(pairs.size() == 2);
  CHECK(pair("0", 3) == Approx(0.2).margin(1e-6));
  CHECK(pair("0", 4) == Approx(0.1).margin(1e-6));
  CHECK(pair("0", 5) == Approx(0.5).margin(1e-6));
  CHECK(pair("0", 6) == Approx(-0.7).margin(1e-6));
  CHECK(pair("1", 3) == Approx(0.05).margin(1e-6));
  CHECK(pair("1", 4) == Approx(0.2).margin(1e-6));
  CHECK(pair("1", 5) == Approx(4).margin(1e-6));
  CHECK(pair("1", 6) == Approx(0.25).margin(1e-6));
  const std::string table = handscs::read_file(dir + "/across.md");
  CHECK(table.find("| decoder_input | scs | 0.850 ± 0.071 | 0.600 ± 0.000 | 0.100 ± 0.000 | 0.700 ± 0.000 (0.500 ± 0.000) |") !=
        std::string::npos);

  SECTION("a folder that is not handscs-features output, pairs of unequal groups, or a k other than the runs' are refused") {
    std::filesystem::create_directories(dir + "/empty");
    const std::string log = dir + "/error.log";
    CHECK(std::system((script + " --out '" + dir + "/x' 'g=" + dir + "/empty' > '" + log + "' 2>&1").c_str()) != 0);
    CHECK(handscs::read_file(log).find(dir + "/empty: no metrics_summary.csv") != std::string::npos);
    CHECK(std::system((script + " --pair scs=plain --out '" + dir + "/x' 'scs=" + dir + "/scs0' 'plain=" + dir +
                       "/plain0," + dir + "/plain1' > '" + log + "' 2>&1").c_str()) != 0);
    CHECK(handscs::read_file(log).find("scs has 1 runs, plain has 2") != std::string::npos);
    CHECK(std::system((script + " --k 10 --out '" + dir + "/x' 'g=" + dir + "/scs0' > '" + log + "' 2>&1").c_str()) != 0);
    CHECK(handscs::read_file(log).find(dir + "/scs0: its k-NN accuracies use k = 1, not --k 10") != std::string::npos);
  }
  std::filesystem::remove_all(dir);
}
