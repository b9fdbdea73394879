// Run-folder safety for handscs-train: a folder that holds a run is never written into by another
// run unless asked (--overwrite), temporaries of killed checkpoint writes are cleaned up, and a
// resume drops the log rows its checkpoint does not cover. What the tools promise: docs/SAFETY.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace handscs {

// The files of one run: what makes a folder hold a run (--overwrite sets them aside: set_aside_run.h). The mask
// cache (cache/) is not among them: it is keyed by a hash of its settings and shared safely.
struct RunFolderContents {
  std::vector<std::string> checkpoints;  // checkpoints/step_*.ckpt, newest first
  bool config = false;                   // config.json
  bool metrics = false;                  // metrics.csv
  bool validation = false;               // validation/
  bool pose_refine = false;              // pose_refine.csv

  bool holds_run() const;
  std::string describe() const;  // e.g. "2 checkpoints (newest step_00000400.ckpt), config.json, metrics.csv"
};

RunFolderContents inspect_run_folder(const std::string& dir);

// Throws Error naming the folder and what it holds when it holds a run and not `overwrite`.
void refuse_run_folder_without_overwrite(const std::string& dir, bool overwrite);

// Removes "<file>.tmp.<pid>" files of write_file_atomic whose writer is no longer running, in dir
// and dir/checkpoints. Returns how many were removed.
int remove_stale_temporaries(const std::string& dir);

// Keeps the header of a metrics log and its rows with iteration <= `iteration` (a resumed run logs
// the later steps again). Atomic; a missing file is left missing.
void truncate_metrics_log(const std::string& path, int64_t iteration);

// Readies a metrics log for rows of `columns` and returns the file's columns, the order in which
// rows must be written (cells by name; a file column the run does not produce stays empty). A new
// file gets `columns` as its header. A log that an earlier run wrote with other columns (an older
// build, or train.cull switched on at a resume) keeps its columns in their order and gains the
// missing ones at the end, its rows padded with empty cells (atomic), so no row is lost, shifted,
// or later dropped as torn. Rows longer than the new header are left as they are (with a warning).
std::vector<std::string> prepare_metrics_log(const std::string& path, const std::vector<std::string>& columns);

}  // namespace handscs
