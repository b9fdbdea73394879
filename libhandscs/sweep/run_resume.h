// A sweep run stopped half-way (the machine went, the job was pre-empted, Ctrl-C) continues from its
// newest checkpoint when the sweep is run again, instead of training from step 0, but only when the
// run folder was started by the same training command, run config and handscs-train binary: a run
// is never finished by other settings or another build than the ones that began it. Resuming is
// exact (the trainer's resume continues the uninterrupted loss curve bit for bit, tests/train), so
// the scores do not depend on where a run stopped. Its row says in resumed_from_step where the last
// attempt began and leaves the training wall time and peak memory empty: they are properties of one
// uninterrupted process, and the last attempt's would understate them.
#pragma once

#include <string>
#include <vector>

namespace handscs {

// What makes two attempts one run: the training command with the run folder's own path written
// as "RUN", the run config as read (its "extends" chain merged), and the size and modification
// time of the handscs-train binary the command calls (argv[0]). JSON text, stored as
// RUN_DIR/sweep_run.json.
std::string sweep_run_identity(const std::vector<std::string>& train_argv, const std::string& run_dir,
                               const std::string& run_config);

// True when run_dir holds sweep_run.json equal to `identity` and at least one checkpoint file
// (checkpoints/step_*.ckpt). The names are matched here rather than through run/checkpoint.h,
// which would link the sweep module to LibTorch; whether a file loads is the trainer's to find
// out (it falls back past damaged ones).
bool sweep_run_resumable(const std::string& run_dir, const std::string& identity);

// Writes RUN_DIR/sweep_run.json (atomically) before a fresh attempt trains.
void record_sweep_run(const std::string& run_dir, const std::string& identity);

// Moves RUN_DIR/train.log aside as train.interrupted.N.log (the first free N from 1), so each
// stopped attempt's log is kept; nothing happens when there is no train.log.
void keep_interrupted_log(const std::string& run_dir);

// From a continued attempt's log: the step it continued from ("resumed from FILE at step N", the
// trainer's line), -1 when it has no such line.
long long resumed_step_in_log(const std::string& train_log);

// True when the log says that none of the run's checkpoints could be loaded (the trainer's error
// "...be resumed; nothing was changed"): the one failure after which the run is trained afresh.
// Any other failure (a missing capture, a full disk, a crash) keeps the folder for the next try.
bool checkpoints_refused_in_log(const std::string& train_log);

}  // namespace handscs
