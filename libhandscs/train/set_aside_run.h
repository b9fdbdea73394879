// --overwrite replaces a run, never removes it first: the earlier run's files are moved into
// RUN/.overwritten.<pid>/ when the new run has passed its checks, and deleted only once the new run
// has written its first checkpoint. A new run that ends before that (an error, an exception) puts
// them back as they were; one that is killed leaves them set aside, and the next handscs-train in
// that folder puts them back (or, when the new run had reached a checkpoint, finishes deleting
// them). What the tools promise: docs/SAFETY.md.
#pragma once

#include <string>

namespace handscs {

class SetAsideRun {
 public:
  // Moves the run files of `dir` (RunFolderContents, plus eval/ and camera_color.csv, which belong
  // to that run) aside. A folder holding no run sets nothing aside. Throws Error naming the file
  // when one cannot be moved, having put back those already moved.
  explicit SetAsideRun(const std::string& dir);
  // Restores the earlier run unless discard() was called; never throws (a failure is logged with
  // where the earlier run's files are).
  ~SetAsideRun();
  SetAsideRun(const SetAsideRun&) = delete;
  SetAsideRun& operator=(const SetAsideRun&) = delete;

  // The new run has its first checkpoint: the earlier run's files are deleted.
  void discard();
  // The new run's files are removed and the earlier run's moved back.
  void restore();

  bool holds_files() const { return !aside_.empty(); }

 private:
  std::string dir_, aside_, described_;
};

// Before anything else in a run folder: an earlier run that a killed --overwrite set aside is put
// back (or deleted, when the killed run had written a checkpoint), with a warning saying which.
// Throws Error when the process that set it aside is still running (two runs in one folder).
void recover_set_aside_runs(const std::string& dir);

}  // namespace handscs
