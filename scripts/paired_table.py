#!/usr/bin/python3
"""Paired differences of a seeded sweep's rows against one reference row, full image and regions.

Points are named <row>.s<seed> (as scripts/ablation_table.py reads them); the runs' eval/summary.json
(handscs-bench --keep-runs keeps runs/<point>_<budget>/) gives PSNR / SSIM / LPIPS of the full image
and of each region (crease / contact / shadow) of realistic captures. Prints a Markdown table: per
row and metric the mean +- sample std over seeds, and against the reference row the paired
difference (row - reference on the same seed) as mean +- sample std, how many seeds improve, and
the per-seed values. Several --out folders of one sweep (shards run side by side with --points)
are read together. Writes the same table to the first folder's paired.md.
Usage: /usr/bin/python3 scripts/paired_table.py SWEEP_OUT [SWEEP_OUT...] --reference off [--budget 2000]
"""
import argparse
import csv
import json
import math
import os
import re
import sys

METRICS = ("psnr", "ssim", "lpips")
BETTER_HIGH = {"psnr": True, "ssim": True, "lpips": False}
DIGITS = {"psnr": 3, "ssim": 4, "lpips": 4}


def mean_std(values):
    if not values:
        return None, None
    m = sum(values) / len(values)
    if len(values) < 2:
        return m, None
    return m, math.sqrt(sum((v - m) ** 2 for v in values) / (len(values) - 1))


def fmt(m, s, digits, sign=False):
    if m is None:
        return ""
    text = f"{m:+.{digits}f}" if sign else f"{m:.{digits}f}"
    return text + (f" ± {s:.{digits}f}" if s is not None else "")


def read_runs(outs, budget):
    """{row: {seed: {"full": {metric: v}, region: {metric: v}}}} from results.csv and summaries."""
    rows, order = {}, []
    for out in outs:
        read_folder(out, budget, rows, order)
    return order, rows


def read_folder(out, budget, rows, order):
    path = os.path.join(out, "results.csv")
    if not os.path.exists(path):  # a shard with no finished run yet
        print(f"paired_table: {path}: not found, skipped", file=sys.stderr)
        return
    with open(path) as f:
        for r in csv.DictReader(f):
            match = re.fullmatch(r"(.+)\.s(\d+)", r["point"])
            if not match or r["status"] != "ok" or (budget and r["budget"] != str(budget)):
                continue
            row, seed = match.group(1), int(match.group(2))
            if row not in rows:
                rows[row] = {}
                order.append(row)
            scores = {"full": {k: float(r[k]) for k in METRICS if r.get(k)}}
            summary = os.path.join(out, "runs", f"{r['point']}_{r['budget']}", "eval", "summary.json")
            if os.path.exists(summary):
                with open(summary) as s:
                    regions = json.load(s).get("regions") or {}
                for name, values in regions.items():
                    if isinstance(values, dict):
                        scores[name] = {k: float(values[k]) for k in METRICS if values.get(k) is not None}
            rows[row][seed] = scores


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="+", help="the sweep's --out folder(s)")
    parser.add_argument("--reference", required=True, help="row the others are paired against")
    parser.add_argument("--budget", type=int, default=0, help="only this budget (0 = any)")
    args = parser.parse_args()
    order, rows = read_runs(args.out, args.budget)
    if args.reference not in rows:
        sys.exit(f"paired_table: no row {args.reference!r} in {', '.join(args.out)} (rows: {', '.join(order)})")
    areas = ["full"] + sorted({a for row in rows.values() for s in row.values() for a in s} - {"full"})
    lines = ["| row | area | seeds | PSNR | SSIM | LPIPS | paired PSNR | paired SSIM | paired LPIPS | "
             "PSNR better on | per-seed PSNR difference |", "|" + "---|" * 11]
    ref = rows[args.reference]
    for row in order:
        for area in areas:
            seeds = sorted(s for s in rows[row] if area in rows[row][s])
            cells = [row, area, str(len(seeds))]
            for k in METRICS:
                cells.append(fmt(*mean_std([rows[row][s][area][k] for s in seeds if k in rows[row][s][area]]),
                                 DIGITS[k]))
            differences = {}
            for k in METRICS:
                differences[k] = [(s, rows[row][s][area][k] - ref[s][area][k]) for s in seeds
                                  if s in ref and area in ref[s] and k in rows[row][s][area]
                                  and k in ref[s][area]]
            if row == args.reference:
                cells += ["", "", "", "", ""]
            else:
                for k in METRICS:
                    cells.append(fmt(*mean_std([d for _, d in differences[k]]), DIGITS[k], sign=True))
                better = sum(1 for _, d in differences["psnr"] if d > 0)
                cells.append(f"{better} of {len(differences['psnr'])}")
                cells.append(" / ".join(f"s{s} {d:+.3f}" for s, d in differences["psnr"]))
            lines.append("| " + " | ".join(cells) + " |")
    text = "\n".join(lines) + "\n"
    with open(os.path.join(args.out[0], "paired.md"), "w") as f:
        f.write(text)
    print(text, end="")


if __name__ == "__main__":
    main()
