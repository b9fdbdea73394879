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
  /usr/bin/python3 scripts/plot_features.py tsne --out PNG [--set SET] [--pose NAME] LABEL=DIR [LABEL=DIR ...]
      one panel per run: t-SNE (scikit-learn, perplexity 30, PCA initialisation, seed 0) of SET
      (default decoder_input) in one pose (default: the first), each Gaussian coloured by its
      phalange; the panel's title gives the run's k-NN accuracy and silhouette for that pose.
  /usr/bin/python3 scripts/plot_features.py check DIR
      recomputes metrics.json's leave-one-out k-NN accuracies (scikit-learn's NearestNeighbors, brute
      force) and silhouettes (sklearn.metrics.silhouette_score), writes DIR/sklearn_check.json, and
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
    from sklearn.neighbors import NearestNeighbors

    _, index = NearestNeighbors(n_neighbors=k + 1, algorithm="brute").fit(x).kneighbors(x)
    right = 0
    for i, row in enumerate(index):
        others = [j for j in row if j != i][:k]
        right += np.bincount(labels[others]).argmax() == labels[i]  # ties: smallest label
    return right / len(labels)


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
            knn = knn_loo_accuracy(x, y, k)
            sil = float(silhouette_score(x, y, metric="euclidean"))
            ours_knn = entry["knn_accuracy"]["per_pose"][p]
            ours_sil = entry["silhouette"]["per_pose"][p]
            agree = (abs(knn - ours_knn) <= KNN_TOLERANCE_VOTES / len(y) + 1e-12 and
                     abs(sil - ours_sil) <= SILHOUETTE_TOLERANCE)
            ok = ok and agree
            rows.append({"pose": pose, "knn_sklearn": knn, "knn_handscs": ours_knn,
                         "silhouette_sklearn": sil, "silhouette_handscs": ours_sil, "agree": bool(agree)})
            print(f"check {name:14s} {pose}: kNN {knn:.6f} vs {ours_knn:.6f}, "
                  f"silhouette {sil:.6f} vs {ours_sil:.6f}{'' if agree else '  DISAGREE'}")
        report["sets"][name] = rows
    report["agree"] = ok
    with open(os.path.join(folder, "sklearn_check.json"), "w") as f:
        json.dump(report, f, indent=2)
    return 0 if ok else 1


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
    for ax, (label, folder) in zip(axes[0], runs):
        meta, poses, labels, values, column = read_run(folder)
        names = meta["label_names"]
        pose = pose_name or meta["poses"][0]
        if pose not in meta["poses"]:
            sys.exit(f"{folder}: no pose {pose} (poses: {', '.join(meta['poses'])})")
        take = poses == pose
        x = standardised(values, column, meta["sets"][feature_set])[take]
        y = labels[take]
        xy = TSNE(n_components=2, perplexity=30, init="pca", learning_rate="auto", random_state=0,
                  n_jobs=1).fit_transform(x)
        for c in range(len(names)):
            m = y == c
            ax.scatter(xy[m, 0], xy[m, 1], s=3, color=colours[c], label=names[c], linewidths=0)
        title = f"{label}: {feature_set} ({x.shape[1]}-D), {pose}"
        try:
            with open(os.path.join(folder, "metrics.json")) as f:
                entry = json.load(f)["sets"][feature_set]
            p = meta["poses"].index(pose)
            title += (f"\nkNN accuracy {entry['knn_accuracy']['per_pose'][p]:.3f}, "
                      f"silhouette {entry['silhouette']['per_pose'][p]:+.3f}")
        except (OSError, KeyError):
            pass
        ax.set_title(title, fontsize=9)
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
                   help="position, embedding, transform, descriptor or decoder_input")
    t.add_argument("--pose", default="", help="pose name (default: each run's first)")
    t.add_argument("runs", nargs="+", metavar="LABEL=DIR", help="a handscs-features output folder and its name")
    c = sub.add_parser("check", help="recompute metrics.json with scikit-learn")
    c.add_argument("folder", metavar="DIR")
    args = parser.parse_args()
    if args.command == "check":
        return check(args.folder)
    runs = []
    for item in args.runs:
        if "=" not in item:
            parser.error(f"{item}: expected LABEL=DIR")
        label, folder = item.split("=", 1)
        runs.append((label, folder))
    return tsne(args.out, runs, args.set, args.pose)


if __name__ == "__main__":
    sys.exit(main())
