#!/usr/bin/python3
"""Structure in the features over training runs: handscs-features' numbers of several avatars of
each kind, their mean and spread over the runs, and the per-run paired differences that read the
paper's Fig. 7 claim (docs/FEATURES.md).

Debian's Python with python3-sklearn. Each DIR is a handscs-features output folder (metrics_summary.csv,
features.csv, features.json). Besides the sets handscs-features scores itself, every run is scored
on two unions of its columns, standardised the same way (scripts/plot_features.py score_per_pose):
  with_p     descriptor+embedding+transform: the SCS decoder input's layout; for a run without SCS
             its decoder input with its own unused P appended (the control);
  without_p  embedding+transform: the decoder input without P, whether the run trained with it or not.

Usage:
  /usr/bin/python3 tools/study/features_across.py --out PREFIX [--pair A=B ...] GROUP=DIR[,DIR...] ...
      GROUP names a kind of avatar (e.g. "full p350"); its DIRs are that kind's runs, in seed order.
      --pair A=B (A with SCS, B without, both GROUPs with as many runs) pairs A's i-th run with B's:
      gap = A's decoder input k-NN accuracy - B's; control = B's with_p - A's decoder input;
      without_p = A's without_p - B's decoder input. The control's share is |control| / |gap|.
  Writes PREFIX.csv (one row per group, set and metric: each run's pose mean, then the mean and the
  sample standard deviation over runs, empty for one run; n/a in the Markdown), PREFIX_pairs.csv (one row per pair and run) and PREFIX.md
  (both as Markdown tables).
"""
import argparse
import csv
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, '..', '..', 'scripts'))  # plot_features.py, which handscs-features runs
from plot_features import read_run, score_per_pose  # noqa: E402  (one home for reading and scoring)
from seed_stats import mean_std, std_text  # noqa: E402  (one home for the mean and spread)

# metrics_summary.csv columns: each set's pose mean, and the across-poses accuracy.
SUMMARY_METRICS = {"knn": "knn_mean", "balanced": "knn_balanced_mean", "silhouette": "silhouette_mean",
                   "across": "knn_transfer", "across_balanced": "knn_transfer_balanced"}
UNIONS = {"with_p": "descriptor+embedding+transform", "without_p": "embedding+transform"}


def run_scores(folder, k):
    """{set: {metric: value}} of one handscs-features folder: its own summary and the two unions,
    the unions voted by the same k as the summary (features.json's knn_k) unless k says otherwise,
    which is refused: the pairs compare a union of one run with the summary of another."""
    path = os.path.join(folder, "metrics_summary.csv")
    if not os.path.isfile(path):
        sys.exit(f"{folder}: no metrics_summary.csv (not a handscs-features output folder)")
    run = read_run(folder)  # features.csv is read once for both unions
    run_k = run[0].get("knn_k")
    if run_k is None:
        sys.exit(f"{folder}/features.json: no knn_k (the k of its k-NN accuracies)")
    if k is not None and k != run_k:
        sys.exit(f"{folder}: its k-NN accuracies use k = {run_k}, not --k {k}")
    k = run_k
    scores = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            scores[row["set"]] = {m: float(row[c]) for m, c in SUMMARY_METRICS.items()}
    for name, sets in UNIONS.items():
        _, rows = score_per_pose(run, sets, k)
        scores[name] = {m: float(np.mean([r[i] for r in rows])) for m, i in
                        (("knn", 1), ("balanced", 2), ("silhouette", 3))}
    return scores


def group_rows(groups, scores):
    rows = []
    for group, folders in groups:
        per_run = [scores[f] for f in folders]
        for name in per_run[0]:
            if not all(name in s for s in per_run):
                continue
            for metric in per_run[0][name]:
                values = [s[name][metric] for s in per_run]
                rows.append((group, name, metric, values) + mean_std(values))
    return rows


def pair_rows(pairs, groups, scores):
    by_name = dict(groups)
    rows = []
    for a, b in pairs:
        for i, (fa, fb) in enumerate(zip(by_name[a], by_name[b])):
            sa, sb = scores[fa], scores[fb]
            gap = sa["decoder_input"]["knn"] - sb["decoder_input"]["knn"]
            control = sb["with_p"]["knn"] - sa["decoder_input"]["knn"]
            without_p = sa["without_p"]["knn"] - sb["decoder_input"]["knn"]
            share = abs(control) / abs(gap) if gap != 0 else float("inf")
            rows.append((a, b, i, gap, control, share, without_p))
    return rows


def write_outputs(prefix, rows, pairs):
    runs = max(len(r[3]) for r in rows)
    with open(prefix + ".csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["group", "set", "metric"] + [f"run{i}" for i in range(runs)] + ["mean", "sd"])
        for group, name, metric, values, mean, sd in rows:
            w.writerow([group, name, metric] + [f"{v:.6f}" for v in values] + [""] * (runs - len(values)) +
                       [f"{mean:.6f}", std_text(sd, 6, missing="")])
    with open(prefix + "_pairs.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["with_scs", "without_scs", "run", "gap", "control", "control_share", "without_p"])
        for a, b, i, gap, control, share, without_p in pairs:
            w.writerow([a, b, i, f"{gap:.6f}", f"{control:.6f}", f"{share:.6f}", f"{without_p:.6f}"])
    table = {}
    for group, name, metric, values, mean, sd in rows:
        table.setdefault((name, group), {})[metric] = f"{mean:.3f} ± {std_text(sd, 3)}"
    lines = ["| set | avatars | k-NN accuracy | balanced | silhouette | across poses (balanced) |",
             "|---|---|---|---|---|---|"]
    for (name, group), m in table.items():
        across = f"{m['across']} ({m['across_balanced']})" if "across" in m else ""
        lines.append(f"| {name} | {group} | {m['knn']} | {m['balanced']} | {m['silhouette']} | {across} |")
    lines += ["", "| with SCS | without | run | gap: decoder input k-NN | control - with SCS | control's share of the gap "
              "| with SCS's input without P - without SCS's |", "|---|---|---|---|---|---|---|"]
    for a, b, i, gap, control, share, without_p in pairs:
        lines.append(f"| {a} | {b} | {i} | {gap:+.4f} | {control:+.4f} | {share:.2f} | {without_p:+.4f} |")
    with open(prefix + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True, help="prefix of the CSV and Markdown files written")
    parser.add_argument("--k", type=int, default=None,
                        help="neighbours of the k-NN vote of the two unions (default, and the only value "
                             "accepted: each folder's own, features.json's knn_k)")
    parser.add_argument("--pair", action="append", default=[], metavar="A=B",
                        help="group A (with SCS) against group B (without), run by run")
    parser.add_argument("groups", nargs="+", metavar="GROUP=DIR[,DIR...]")
    args = parser.parse_args()
    groups = []
    for item in args.groups:
        name, sep, dirs = item.partition("=")
        if not sep or not dirs:
            parser.error(f"{item}: expected GROUP=DIR[,DIR...]")
        groups.append((name, dirs.split(",")))
    names = dict(groups)
    pairs = []
    for item in args.pair:
        a, sep, b = item.partition("=")
        if not sep or a not in names or b not in names:
            parser.error(f"--pair {item}: expected A=B, both among the groups ({', '.join(names)})")
        if len(names[a]) != len(names[b]):
            parser.error(f"--pair {item}: {a} has {len(names[a])} runs, {b} has {len(names[b])}")
        pairs.append((a, b))
    scores = {f: run_scores(f, args.k) for _, folders in groups for f in folders}
    write_outputs(args.out, group_rows(groups, scores), pair_rows(pairs, groups, scores))
    return 0


if __name__ == "__main__":
    sys.exit(main())
