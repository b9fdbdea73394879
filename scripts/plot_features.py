#!/usr/bin/python3
"""t-SNE plots (paper Fig. 7) and a scikit-learn check of what handscs-features writes.

Debian's Python with python3-sklearn and python3-matplotlib. handscs-features writes, in its output
folder DIR:
  features.csv   one row per Gaussian and pose: pose, gaussian, label (the phalange: argmax of the
                 Gaussian's 16 skinning weights, MANO joint order), then its position, embedding,
                 transform and descriptor columns;
  features.json  which columns make each feature set (the decoder input is P, e_g, e_a, vec(T) with
                 SCS and e_g, e_a, vec(T) without), the label names, the run's label;
  metrics.json   its k-NN accuracies and silhouettes per feature set and pose.
Every feature set is standardised as handscs-features does it: each column to mean 0 and population
standard deviation 1 over the poses pooled (a constant column is centred only).

Usage:
  /usr/bin/python3 scripts/plot_features.py tsne --out PNG [--set SET] [--pose NAME] LABEL=DIR[#SET] ...
      one panel per run: t-SNE (scikit-learn, perplexity 30, PCA initialisation, seed 0) of SET
      (default decoder_input; a run's own #SET overrides it; SET may be a union A+B+...) in one pose
      (default: the first), each Gaussian coloured by its phalange; the panel's title gives the
      k-NN accuracy (k from features.json) and silhouette of those points.
  /usr/bin/python3 scripts/plot_features.py score DIR SET+SET[+...] [--k 10]
      scores a union of feature sets that handscs-features does not score itself (e.g.
      descriptor+embedding+transform of a run without SCS: its decoder input with P appended, the
      control for how much of the SCS run's clustering P brings by construction): the leave-one-out
      k-NN accuracy, balanced accuracy and silhouette per pose, their mean and sample standard
      deviation.
  /usr/bin/python3 scripts/plot_features.py check DIR
      recomputes metrics.json's leave-one-out k-NN accuracies and balanced accuracies (scikit-learn's
      NearestNeighbors, brute force, and its accuracy scores) and silhouettes (sklearn.metrics.silhouette_score), writes DIR/sklearn_check.json, and
      exits 1 when they disagree beyond the tolerances below.
"""
import argparse
import csv
import json
import os
import sys

import numpy as np

# Silhouettes agree to rounding; k-NN accuracies may differ by a vote or two where neighbours lie at
# exactly equal distances (scikit-learn orders such ties arbitrarily, handscs-features by index).
SILHOUETTE_TOLERANCE = 1e-6
KNN_TOLERANCE_VOTES = 2
# A column whose standard deviation is below this share of its largest |value| is constant up to
# rounding (the same rule as libhandscs/infer/feature_pca.cpp).
CONSTANT_COLUMN = 1e-9


def read_run(folder):
    with open(os.path.join(folder, "features.json")) as f:
        meta = json.load(f)
    with open(os.path.join(folder, "features.csv"), newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = list(reader)
    poses = np.array([r[0] for r in rows])
    labels = np.array([int(r[2]) for r in rows])
    values = np.array([[float(v) for v in r[3:]] for r in rows])
    column = {name: i for i, name in enumerate(header[3:])}
    return meta, poses, labels, values, column


def standardised(values, column, names):
    x = values[:, [column[n] for n in names]]
    mean = x.mean(0)
    std = np.sqrt(((x - mean) ** 2).mean(0))
    magnitude = np.maximum(np.abs(x).max(0), 1e-300)
    scale = np.where(std > CONSTANT_COLUMN * magnitude, std, 1.0)
    return (x - mean) / scale


def knn_loo_accuracy(x, labels, k):
    """(accuracy, balanced accuracy) of the leave-one-out k-NN vote, scikit-learn's neighbours."""
    from sklearn.metrics import accuracy_score, balanced_accuracy_score
    from sklearn.neighbors import NearestNeighbors

    _, index = NearestNeighbors(n_neighbors=k + 1, algorithm="brute").fit(x).kneighbors(x)
    predicted = np.empty_like(labels)
    for i, row in enumerate(index):
        others = [j for j in row if j != i][:k]
        predicted[i] = np.bincount(labels[others]).argmax()  # ties: smallest label
    return accuracy_score(labels, predicted), balanced_accuracy_score(labels, predicted)


def check(folder):
    from sklearn.metrics import silhouette_score

    meta, poses, labels, values, column = read_run(folder)
    with open(os.path.join(folder, "metrics.json")) as f:
        metrics = json.load(f)
    k = metrics["k"]
    report = {"k": k, "sets": {}}
    ok = True
    for name, entry in metrics["sets"].items():
        x_all = standardised(values, column, meta["sets"][name])
        rows = []
        for p, pose in enumerate(meta["poses"]):
            take = poses == pose
            x, y = x_all[take], labels[take]
            knn, balanced = knn_loo_accuracy(x, y, k)
            sil = float(silhouette_score(x, y, metric="euclidean"))
            ours_knn = entry["knn_accuracy"]["per_pose"][p]
            ours_balanced = entry["knn_balanced_accuracy"]["per_pose"][p]
            ours_sil = entry["silhouette"]["per_pose"][p]
            # A flipped vote moves the accuracy by 1 / N and the balanced accuracy by at most
            # 1 / (smallest label's size x number of labels).
            counts = np.bincount(y)
            counts = counts[counts > 0]
            agree = (abs(knn - ours_knn) <= KNN_TOLERANCE_VOTES / len(y) + 1e-12 and
                     abs(balanced - ours_balanced) <= KNN_TOLERANCE_VOTES / (counts.min() * len(counts)) + 1e-12 and
                     abs(sil - ours_sil) <= SILHOUETTE_TOLERANCE)
            ok = ok and agree
            rows.append({"pose": pose, "knn_sklearn": knn, "knn_handscs": ours_knn,
                         "knn_balanced_sklearn": balanced, "knn_balanced_handscs": ours_balanced,
                         "silhouette_sklearn": sil, "silhouette_handscs": ours_sil, "agree": bool(agree)})
            print(f"check {name:18s} {pose}: kNN {knn:.6f} vs {ours_knn:.6f}, balanced {balanced:.6f} vs "
                  f"{ours_balanced:.6f}, silhouette {sil:.6f} vs {ours_sil:.6f}{'' if agree else '  DISAGREE'}")
        report["sets"][name] = rows
    report["agree"] = ok
    with open(os.path.join(folder, "sklearn_check.json"), "w") as f:
        json.dump(report, f, indent=2)
    return 0 if ok else 1


def columns_of(meta, sets):
    names = []
    for name in sets.split("+"):
        if name not in meta["sets"]:
            sys.exit(f"no feature set {name} (sets: {', '.join(meta['sets'])})")
        names += [c for c in meta["sets"][name] if c not in names]
    return names


def score_per_pose(run, sets, k):
    """(column count, [(pose, k-NN accuracy, balanced accuracy, silhouette)]) of a union of feature
    sets of `run` (read_run's tuple), standardised over the poses pooled as handscs-features does it."""
    from sklearn.metrics import silhouette_score

    meta, poses, labels, values, column = run
    names = columns_of(meta, sets)
    x_all = standardised(values, column, names)
    rows = []
    for pose in meta["poses"]:
        take = poses == pose
        a, b = knn_loo_accuracy(x_all[take], labels[take], k)
        rows.append((pose, a, b, float(silhouette_score(x_all[take], labels[take], metric="euclidean"))))
    return len(names), rows


def score(folder, sets, k):
    run = read_run(folder)
    meta = run[0]
    dims, rows = score_per_pose(run, sets, k)
    for pose, a, b, s in rows:
        print(f"{meta['label']} {sets} ({dims}-D) {pose}: kNN {a:.4f}, balanced {b:.4f}, silhouette {s:+.4f}")
    knn, balanced, sil = ([r[i] for r in rows] for i in (1, 2, 3))
    ddof = 1 if len(knn) > 1 else 0
    print(f"{meta['label']} {sets} ({dims}-D): kNN {np.mean(knn):.4f} +- {np.std(knn, ddof=ddof):.4f}, "
          f"balanced {np.mean(balanced):.4f} +- {np.std(balanced, ddof=ddof):.4f}, "
          f"silhouette {np.mean(sil):+.4f} +- {np.std(sil, ddof=ddof):.4f} (mean +- sample sd over poses)")
    return 0


# Phalange colours: one hue per finger, lighter towards the tip; the wrist (palm) grey.
def label_colours():
    import matplotlib

    colours = [(0.45, 0.45, 0.45)]
    # MANO order after the wrist: index, middle, pinky, ring, thumb (three joints each).
    for cmap in ("Blues", "Greens", "Purples", "Oranges", "Reds"):
        ramp = matplotlib.colormaps[cmap]
        colours += [ramp(v) for v in (0.95, 0.7, 0.45)]
    return colours


def tsne(out, runs, feature_set, pose_name):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from sklearn.manifold import TSNE

    colours = label_colours()
    legend_width = 1.5  # inches on the right for the legend, beside the panels
    width = 5.2 * len(runs) + legend_width
    fig, axes = plt.subplots(1, len(runs), figsize=(width, 5.4), squeeze=False)
    names = None
    from sklearn.metrics import silhouette_score

    for ax, (label, folder, own_set) in zip(axes[0], runs):
        panel_set = own_set or feature_set
        meta, poses, labels, values, column = read_run(folder)
        names = meta["label_names"]
        pose = pose_name or meta["poses"][0]
        if pose not in meta["poses"]:
            sys.exit(f"{folder}: no pose {pose} (poses: {', '.join(meta['poses'])})")
        take = poses == pose
        x = standardised(values, column, columns_of(meta, panel_set))[take]
        y = labels[take]
        xy = TSNE(n_components=2, perplexity=30, init="pca", learning_rate="auto", random_state=0,
                  n_jobs=1).fit_transform(x)
        for c in range(len(names)):
            m = y == c
            ax.scatter(xy[m, 0], xy[m, 1], s=3, color=colours[c], label=names[c], linewidths=0)
        k = meta.get("knn_k", 10)
        accuracy, balanced = knn_loo_accuracy(x, y, k)
        ax.set_title(f"{label}: {panel_set} ({x.shape[1]}-D), {pose}\n"
                     f"kNN accuracy {accuracy:.3f} (balanced {balanced:.3f}), "
                     f"silhouette {silhouette_score(x, y, metric='euclidean'):+.3f}", fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
    handles = [plt.Line2D([], [], marker="o", linestyle="", color=colours[c], markersize=5)
               for c in range(len(names))]
    fig.tight_layout(rect=(0, 0, 1 - legend_width / width, 1))
    fig.legend(handles, names, loc="center left", bbox_to_anchor=(1 - legend_width / width, 0.5), fontsize=8,
               title="phalange\n(argmax of w)", title_fontsize=8, frameon=False)
    temp = f"{out}.tmp.{os.getpid()}.png"  # atomic: never a half-written picture
    fig.savefig(temp, dpi=130)
    os.replace(temp, out)
    print(f"wrote {out}")
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("tsne", help="t-SNE of one feature set in one pose, one panel per run")
    t.add_argument("--out", required=True, help="PNG to write")
    t.add_argument("--set", default="decoder_input",
                   help="position, embedding, transform, descriptor, descriptor_static, descriptor_virtual, decoder_input, or a union A+B")
    t.add_argument("--pose", default="", help="pose name (default: each run's first)")
    t.add_argument("runs", nargs="+", metavar="LABEL=DIR[#SET]",
                   help="a handscs-features output folder, its name, and optionally its own feature set")
    sc = sub.add_parser("score", help="k-NN accuracy and silhouette of a union of feature sets")
    sc.add_argument("folder", metavar="DIR")
    sc.add_argument("sets", metavar="SET+SET", help="e.g. descriptor+embedding+transform")
    sc.add_argument("--k", type=int, default=10, help="neighbours of the k-NN vote")
    c = sub.add_parser("check", help="recompute metrics.json with scikit-learn")
    c.add_argument("folder", metavar="DIR")
    args = parser.parse_args()
    if args.command == "check":
        return check(args.folder)
    if args.command == "score":
        return score(args.folder, args.sets, args.k)
    runs = []
    for item in args.runs:
        if "=" not in item:
            parser.error(f"{item}: expected LABEL=DIR or LABEL=DIR#SET")
        label, folder = item.split("=", 1)
        folder, _, own_set = folder.partition("#")
        runs.append((label, folder, own_set))
    return tsne(args.out, runs, args.set, args.pose)


if __name__ == "__main__":
    sys.exit(main())
