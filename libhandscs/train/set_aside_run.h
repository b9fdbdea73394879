// A new run never removes an earlier one first, and one that fails leaves no half run behind.
// --overwrite moves the earlier run's files into RUN/.overwritten.<pid>/ when the new run has passed
// its checks, and deletes them only once the new run has written its first checkpoint. A new run
// that ends before that (an error, an exception) removes the run files it wrote and puts the
// earlier run's back as they were; so a fresh run stopped by a user error at step 16 leaves the
// folder as it found it, and a rerun needs no --overwrite. One that is killed leaves the earlier
// run set aside, and the next handscs-train in that folder puts it back (or, when the new run had
// reached a checkpoint, finishes deleting it). What the tools promise: docs/SAFETY.md.
#pragma once

#include <string>
#include <vector>

namespace handscs {

class SetAsideRun {
 public:
  // Moves the run files of `dir` (RunFolderContents, plus eval/, camera_color.csv and the second
  // hand's left/, which belong to that run) aside. A folder holding no run sets nothing aside; run
  // files in it then (a user's own eval/) are not the new run's and stay. Throws Error naming the
  // file when one cannot be moved, having put back those already moved.
  explicit SetAsideRun(const std::string& dir);
  // restore() unless discard() was called; never throws (a failure is logged with where the
  // earlier run's files are).
  ~SetAsideRun();
  SetAsideRun(const SetAsideRun&) = delete;
  SetAsideRun& operator=(const SetAsideRun&) = delete;

  // The new run has its first checkpoint: its files stay, the earlier run's are deleted.
  void discard();
  // The new run's files are removed and the earlier run's, if any, moved back.
  void restore();

  bool holds_files() const { return !aside_.empty(); }

 private:
  std::string dir_, aside_, described_;
  std::vector<std::string> kept_;  // run file names in `dir` that were not set aside
  bool settled_ = false;           // discard() or restore() has run
};

// Before anything else in a run folder: an earlier run that a killed --overwrite set aside is put
// back (or deleted, when the killed run had written a checkpoint), with a warning saying which.
// Throws Error when the process that set it aside is still running (two runs in one folder).
void recover_set_aside_runs(const std::string& dir);

}  // namespace handscs
