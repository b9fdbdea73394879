#!/usr/bin/python3
"""A gain with the capture as a factor (docs/SCALING.md, "The capture as a factor").

    /usr/bin/python3 tools/study/capture_factor.py \
        --capture seed1=docs/bench/scaling_view_10000_tau003.csv,docs/bench/scaling_view_10000.csv \
        --capture seed2=out/view_captures.C2 --capture seed3=out/view_captures.C3 \
        --gain scs=full_tau003-inter_pose_tau003 --gain embeddings=embedding-baseline \
        [--cell view] [--budget 10000] [--seeds 3] [--holds pays|none] [--out PREFIX]

Each --capture names one capture and the handscs-bench output folders (or their results.csv files)
that hold its runs, comma-separated. Points are named <row>.<cell>.s<seed>. For every --gain
ROW-BASE: per capture, the PSNR gain paired by seed, its mean and sample std over the seeds and
the study's rule (pays: positive on every seed; costs: negative on every seed; otherwise no
difference shown; incomplete until --seeds pairs are in). Across captures, a random factor: the
mean and sample std of the per-capture mean gains, and the reading declared before the runs: a gain
holds across captures if it pays on every capture (--holds pays); "no difference" holds across
captures if no capture shows the gain paying or costing (--holds none, for a cell that showed no
difference on one capture). SSIM and LPIPS gains are given beside it.
Writes PREFIX.md and prints it.
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from confirm_rule import paired  # noqa: E402
from paired_gains import parse_gain, read_sweep, reading  # noqa: E402
from seed_stats import mean_std  # noqa: E402


def capture_runs(folders, budget):
    """{(row, cell, budget, seed): metrics} of one capture's runs at the budget (later folders win)."""
    runs = {}
    for folder in folders:
        results, _ = read_sweep(folder)
        runs.update({key: values for key, values in results.items() if key[2] == budget})
    return runs


def rule(gains, seeds):
    """The study's reading of one capture's paired gains ({seed: gain}), once all seeds are in."""
    if len(gains) < seeds:
        return f'incomplete ({len(gains)} of {seeds} seeds)'
    return reading(list(gains.values()))


def fmt(value, digits=3, signed=True):
    if value is None:
        return 'n/a'
    return f'{value:+.{digits}f}' if signed else f'{value:.{digits}f}'


def verdict_of(readings, holds):
    """The declared reading across captures of the complete captures' readings."""
    pays = sum(r == 'pays' for r in readings)
    costs = sum(r == 'costs' for r in readings)
    if holds == 'none':
        if pays == costs == 0:
            return 'no difference holds across captures (no capture shows a gain or a cost)'
        return (f'no difference does not hold across captures: pays on {pays}, costs on {costs} '
                f'of {len(readings)}')
    if pays == len(readings):
        return 'holds across captures (pays on every capture)'
    return f'does not hold across captures: pays on {pays} of {len(readings)}'


def analyse(captures, gains, cell, budget, seeds, holds='pays'):
    """Rows of the table and the across-capture verdicts, as text lines."""
    lines = [f'# Gains with the capture as a factor ({cell} cell, {budget} steps)', '']
    for name, (row, base) in gains.items():
        lines += [f'## {name}: {row} - {base}', '',
                  '| capture | PSNR gain per seed (dB) | mean ± std | reading | SSIM | LPIPS |',
                  '|---|---|---|---|---|---|']
        means, readings = [], []
        for capture, runs in captures.items():
            psnr = paired(runs, row, base, cell, 'psnr')
            mean, std = mean_std(list(psnr.values()))
            reading = rule(psnr, seeds)
            ssim_mean, _ = mean_std(list(paired(runs, row, base, cell, 'ssim').values()))
            lpips_mean, _ = mean_std(list(paired(runs, row, base, cell, 'lpips').values()))
            per_seed = ' / '.join(f's{s} {fmt(g)}' for s, g in psnr.items()) or 'none'
            lines.append(f'| {capture} | {per_seed} | {fmt(mean)} ± {fmt(std, signed=False)} | {reading} | '
                         f'{fmt(ssim_mean, 4)} | {fmt(lpips_mean, 4)} |')
            readings.append(reading)
            if not reading.startswith('incomplete'):
                means.append(mean)
        lines.append('')
        complete = len(means) == len(captures)
        across_mean, across_std = mean_std(means)
        lines.append(f'Across {len(means)} complete of {len(captures)} captures: mean of the per-capture means '
                     f'{fmt(across_mean)} ± {fmt(across_std, signed=False)} dB.')
        if not complete:
            verdict = f'no verdict yet: {len(captures) - len(means)} capture(s) incomplete'
        else:
            verdict = verdict_of(readings, holds)
        lines += [f'Reading: **{verdict}**.', '']
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--capture', action='append', required=True, help='NAME=FOLDER_OR_CSV[,...]')
    parser.add_argument('--gain', action='append', required=True, help='NAME=ROW-BASE')
    parser.add_argument('--cell', default='view')
    parser.add_argument('--budget', type=int, default=10000)
    parser.add_argument('--seeds', type=int, default=3, help='pairs a capture needs for a reading')
    parser.add_argument('--holds', choices=['pays', 'none'], default='pays',
                        help='the reading that holds across captures: the gain pays on every capture, '
                             'or no capture shows a gain or a cost')
    parser.add_argument('--out', help='write PREFIX.md')
    args = parser.parse_args()
    captures = {}
    for spec in args.capture:
        name, sep, folders = spec.partition('=')
        if not sep or not folders:
            sys.exit(f'--capture {spec}: expected NAME=FOLDER[,FOLDER...]')
        captures[name] = capture_runs(folders.split(','), args.budget)
    gains = {}
    for spec in args.gain:
        name, row, row_budget, base, base_budget = parse_gain(spec)
        if row_budget is not None or base_budget is not None:
            sys.exit(f'--gain {spec}: both rows are read at --budget; give NAME=ROW-BASE')
        gains[name] = (row, base)
    text = '\n'.join(analyse(captures, gains, args.cell, args.budget, args.seeds, args.holds))
    print(text)
    if args.out:
        with open(args.out + '.md', 'w') as f:
            f.write(text)


if __name__ == '__main__':
    main()
