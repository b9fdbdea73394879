#!/usr/bin/python3
"""Summarise a seeded ablation sweep (configs/sweeps/ablation_real*.json) over its seeds.

Points are named <row>.s<seed>; this groups the sweep's results.csv by row and writes, next to it:
  ablation.md   mean +- sample std (n seeds) of PSNR / SSIM / LPIPS per row, the paper's numbers
                (HandSCS Tables 3 and 4, test/Capture0) beside the rows they correspond to, the
                region PSNR / SSIM / LPIPS (e.g. crease / contact / shadow, or the hands of a real
                capture; each region's PSNR of its pooled MSE) when the runs' eval/summary.json has
                them, and the training wall time and peak memory; a cell that only some seeds have a
                finite value for says "(k of n seeds)";
  ablation.csv  the same numbers, one line per row, with how many seeds each mean is over;
  ablation.png / ablation.pdf  each row's mean with its spread (error bar = std, dots = seeds).
Usage: /usr/bin/python3 tools/study/ablation_table.py SWEEP_OUT [--title TEXT]
"""
import argparse
import csv
import json
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from seed_stats import finite_mean_std  # noqa: E402  (one home for the mean and spread)

# HandSCS Tables 3 and 4 (test/Capture0): PSNR, SSIM, LPIPS.
PAPER = {
    "baseline": (31.71, 0.958, 0.0428),
    "embedding": (32.23, 0.961, 0.0337),
    "embedding_reg": (32.32, 0.963, 0.0339),
    "inter_pose": (32.42, 0.964, 0.0335),
    "scs": (32.78, 0.966, 0.0301),
    "full": (32.91, 0.966, 0.0291),
    "virtual_only": (32.64, 0.965, 0.0302),
    "static_only": (32.70, 0.965, 0.0311),
}
# ablation_real_2000_rest.json names row (d) for what it is: SCS without the inter-pose term.
PAPER["scs_no_inter_pose"] = PAPER["scs"]
LABELS = {
    "baseline": "(a) baseline",
    "embedding": "(b) + embeddings",
    "embedding_reg": "(b) + L_reg",
    "inter_pose": "(c) + inter-pose",
    "scs": "(d) + SCS",
    "scs_no_inter_pose": "(d) + SCS, no inter-pose",
    "full": "full model",
    "static_only": "static bones only (M = 0)",
    "virtual_only": "virtual bones only",
    "m8": "M = 8",
    "m32": "M = 32",
    "con_1e-3": "lambda_con = 1e-3 (mean)",
    "con_1e-2": "lambda_con = 1e-2 (mean)",
    "con_1e-1": "lambda_con = 1e-1 (mean)",
    "con_sum": "L_con summed (paper's formula)",
    "con_groups": "L_con per-group normalised",
    "reg_all": "L_reg with fusion offsets",
    "reg_1e-2": "lambda_reg = 1e-2",
    "reg_0": "lambda_reg = 0",
    "scs_open": "(b) + SCS, decoders open (lambda_reg = 0, no L_con)",
}
METRICS = ("psnr", "ssim", "lpips")
# What each run cost (results.csv): training wall time (s) and peak resident memory (MB).
COSTS = ("train_wall_s", "peak_rss_mb")


def fmt(stats, digits, seeds):
    """finite_mean_std's (mean, std, count) as "mean ± std", with "(k of n seeds)" after it when
    only k of the row's n seeds have a finite value."""
    m, s, count = stats
    if m is None:
        return ""
    text = f"{m:.{digits}f}" + (f" ± {s:.{digits}f}" if s is not None else "")
    return text + (f" ({count} of {seeds} seeds)" if count < seeds else "")


def read_rows(out):
    path = os.path.join(out, "results.csv")
    if not os.path.exists(path):
        sys.exit(f"ablation_table: {path}: not found (run handscs-bench --sweep first)")
    groups = {}
    order = []
    with open(path) as f:
        for r in csv.DictReader(f):
            match = re.fullmatch(r"(.+)\.s(\d+)", r["point"])
            if not match or r["status"] != "ok":
                continue
            row, seed = match.group(1), int(match.group(2))
            if row not in groups:
                groups[row] = []
                order.append(row)
            entry = {k: float(r[k]) for k in METRICS + COSTS if r.get(k)}
            entry["seed"] = seed
            # handscs-bench keeps each run (--keep-runs) in runs/<point>_<budget>/.
            summary = os.path.join(out, "runs", f"{r['point']}_{r['budget']}", "eval", "summary.json")
            if os.path.exists(summary):
                with open(summary) as s:
                    regions = json.load(s).get("regions") or {}
                for name, values in regions.items():
                    for k in METRICS:
                        # A region's PSNR of its pooled MSE: its mean of per-image PSNRs is infinite
                        # when the region matches exactly in one image (docs/METRICS.md).
                        key = "psnr_pooled_mse" if k == "psnr" else k
                        if isinstance(values, dict) and values.get(key) is not None:
                            entry[f"{name}_{k}"] = float(values[key])
            groups[row].append(entry)
    return order, groups


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="the sweep's --out folder")
    parser.add_argument("--title", default="HandSCS ablation")
    args = parser.parse_args()
    order, groups = read_rows(args.out)
    region_names = sorted({k.rsplit("_", 1)[0] for g in groups.values() for e in g for k in e
                           if k.endswith(("_psnr",)) and k != "psnr"})
    header = ["row", "seeds", "PSNR", "SSIM", "LPIPS", "paper PSNR / SSIM / LPIPS"]
    for r in region_names:
        header += [f"{r} PSNR", f"{r} SSIM", f"{r} LPIPS"]
    header += ["train s", "peak MB"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    csv_rows = []
    for row in order:
        entries = groups[row]
        stats = {k: finite_mean_std([e.get(k) for e in entries]) for k in METRICS}
        paper = PAPER.get(row)
        n = len(entries)
        cells = [LABELS.get(row, row), str(n), fmt(stats["psnr"], 2, n), fmt(stats["ssim"], 4, n),
                 fmt(stats["lpips"], 4, n), f"{paper[0]:.2f} / {paper[1]:.3f} / {paper[2]:.4f}" if paper else ""]
        for r in region_names:
            for k, digits in (("psnr", 2), ("ssim", 4), ("lpips", 4)):
                cells.append(fmt(finite_mean_std([e.get(f"{r}_{k}") for e in entries]), digits, n))
        for k in COSTS:
            cells.append(fmt(finite_mean_std([e.get(k) for e in entries]), 0, n))
        lines.append("| " + " | ".join(cells) + " |")
        csv_rows.append([row, len(entries)] + [x for k in METRICS for x in stats[k]])
    with open(os.path.join(args.out, "ablation.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(args.out, "ablation.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["row", "seeds"] + [f"{k}_{s}" for k in METRICS for s in ("mean", "std", "seeds")])
        w.writerows(csv_rows)
    print("\n".join(lines))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 0.45 * len(order) + 1.6), sharey=True)
    for ax, key, name in ((axes[0], "psnr", "PSNR (dB) ↑"), (axes[1], "lpips", "LPIPS ↓")):
        for y, row in enumerate(order):
            values = [e[key] for e in groups[row] if key in e]
            m, s, _ = finite_mean_std(values)
            if m is None:
                continue
            ax.errorbar(m, y, xerr=s or 0, fmt="o", color="C0", capsize=3)
            ax.plot(values, [y] * len(values), ".", color="C1", alpha=0.7)
        ax.set_xlabel(name)
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(order)))
    axes[0].set_yticklabels([LABELS.get(r, r) for r in order])
    axes[0].invert_yaxis()
    fig.suptitle(f"{args.title}: mean ± std over seeds (dots: seeds)")
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(os.path.join(args.out, f"ablation.{ext}"), dpi=120)


if __name__ == "__main__":
    main()
