#!/usr/bin/python3
"""Draw a handscs-bench sweep's charts with matplotlib (Debian: python3-matplotlib).

Reads, in the sweep's output folder OUT (handscs-bench calls this after every sweep, merge and
--plots-only):
  results.csv  one row per (point, budget) run: training wall time, novel-pose PSNR and LPIPS;
  pareto.csv   which runs are on the PSNR and LPIPS Pareto fronts (worked out by handscs-bench,
               sweep/pareto.h, so summary.md and the charts agree);
  raster.csv   rasterizer timings over N and threads (optional).
Writes, each as PNG (for Markdown) and PDF (vector, for papers):
  psnr_vs_time, lpips_vs_time   one line per point over its budgets, the Pareto front dashed;
  raster_ms_vs_n                rasterizer forward + backward ms against N, one line per thread count.
Usage: /usr/bin/python3 scripts/plot_sweep.py OUT
"""
import csv
import math
import os
import sys


def number(text):
    try:
        value = float(text)
    except (TypeError, ValueError):
        return math.nan
    return value


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def save(fig, out_dir, name):
    for ext in ("png", "pdf"):
        target = os.path.join(out_dir, f"{name}.{ext}")
        temp = f"{target}.tmp.{os.getpid()}.{ext}"  # atomic: never a half-written chart
        fig.savefig(temp, dpi=150 if ext == "png" else None, bbox_inches="tight")
        os.replace(temp, target)


def plain_log_ticks(axis):
    """Log-axis ticks at 1, 2, 5 x 10^k labelled as plain numbers (0.5, 2, 1000), not 2x10^0."""
    from matplotlib import ticker
    axis.set_major_locator(ticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(ticker.FuncFormatter(lambda value, _: f"{value:g}"))
    axis.set_minor_formatter(ticker.NullFormatter())


def quality_charts(plt, out_dir):
    path = os.path.join(out_dir, "results.csv")
    if not os.path.exists(path):
        return
    rows = [r for r in read_rows(path) if r.get("status") == "ok"]
    fronts = {}
    pareto_path = os.path.join(out_dir, "pareto.csv")
    if os.path.exists(pareto_path):
        for r in read_rows(pareto_path):
            fronts.setdefault(r["metric"], set()).add((r["point"], r["budget"]))
    order = []
    for r in rows:
        if r["point"] not in order:
            order.append(r["point"])
    for metric, label in (("psnr", "PSNR (dB), higher is better"),
                          ("lpips", "LPIPS-alex, lower is better")):
        fig, ax = plt.subplots(figsize=(8, 5.3))
        drawn = False
        for name in order:
            runs = sorted((r for r in rows if r["point"] == name), key=lambda r: number(r["budget"]))
            xs = [number(r["train_wall_s"]) / 60.0 for r in runs]
            ys = [number(r[metric]) for r in runs]
            keep = [(x, y) for x, y in zip(xs, ys) if x > 0 and math.isfinite(y)]
            if keep:
                ax.plot(*zip(*keep), marker="o", markersize=4, linewidth=1.4, label=name)
                drawn = True
        on_front = [r for r in rows if (r["point"], r["budget"]) in fronts.get(metric, set())]
        front = sorted((number(r["train_wall_s"]) / 60.0, number(r[metric])) for r in on_front)
        front = [(x, y) for x, y in front if x > 0 and math.isfinite(y)]
        if front:
            ax.plot(*zip(*front), linestyle="--", color="0.55", linewidth=1.2, label="Pareto front")
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)
        ax.set_xlabel("training wall time (min)")
        ax.set_ylabel(label)
        ax.set_title(f"Novel-pose {metric.upper()} against training wall time")
        ax.grid(True, which="both", alpha=0.3)
        if drawn:
            ax.legend(fontsize=8, ncol=2 if len(order) > 8 else 1)
        save(fig, out_dir, f"{metric}_vs_time")
        plt.close(fig)


def raster_chart(plt, out_dir):
    path = os.path.join(out_dir, "raster.csv")
    if not os.path.exists(path):
        return
    by_threads = {}
    for r in read_rows(path):
        by_threads.setdefault(r["threads"], []).append((number(r["gaussians"]), number(r["total_ms"])))
    fig, ax = plt.subplots(figsize=(8, 5.3))
    for threads in sorted(by_threads, key=number):
        points = sorted((n, ms) for n, ms in by_threads[threads] if n > 0 and ms > 0)
        if points:
            ax.plot(*zip(*points), marker="o", markersize=4,
                    label=f"{threads} thread{'' if threads == '1' else 's'}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax.xaxis)
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel("Gaussians N")
    ax.set_ylabel("ms (median)")
    ax.set_title("Rasterizer forward + backward, 512x334")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    save(fig, out_dir, "raster_ms_vs_n")
    plt.close(fig)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out_dir = sys.argv[1]
    try:
        import matplotlib
    except ImportError:
        sys.exit("plot_sweep.py: matplotlib is not installed (Debian: apt-get install "
                 "python3-matplotlib); the CSVs and summary.md are complete without the charts")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    quality_charts(plt, out_dir)
    raster_chart(plt, out_dir)


if __name__ == "__main__":
    main()
