#!/usr/bin/python3
"""Paired gains of a seeded study: what one row adds over another, cell by cell, seed by seed.

    /usr/bin/python3 tools/study/paired_gains.py SWEEP_OUT... --gain NAME=ROW-BASE ... [--out PREFIX]
        [--gain NAME=ROW@BUDGET-BASE@BUDGET ...]
        [--gain-change NAME=GAIN-BASE_GAIN ...] [--frames FRAMES.csv] [--plot-gain NAME ...]
        [--title TEXT]

Each SWEEP_OUT is a handscs-bench output folder (results.csv, and runs/<point>_<budget>/eval/
summary.json, when the sweep kept its runs, for the region metrics and full-precision means). Points
are named <row>.<cell>.s<seed> (for example full.p350.s10: row full, cell p350, seed 10), or
<row>.s<seed> (one cell). A cell is the pair (cell name, budget). For every --gain NAME=ROW-BASE
(e.g. scs=full-inter_pose) and cell, the gain of each seed present in both rows is ROW's metric
minus BASE's, for PSNR, SSIM, LPIPS and the region PSNRs (each region's PSNR of its pooled MSE).
--gain NAME=ROW@B1-BASE@B2 pairs two budgets instead: in every cell name, ROW at B1 steps minus BASE
at B2 (e.g. full@10000-inter_pose@2000: the full model's long run against row (c)'s short one; or
inter_pose@10000-inter_pose@2000: what the longer budget does to one row); its budget reads "B1 vs
B2".
Writes PREFIX.md (a Markdown table: mean +- sample std over the seeds, each seed's value, and the
reading rule of docs/SCALING.md: "pays" if the PSNR gain is positive on every seed and there are at
least 2, "costs" if negative on every seed, otherwise "no difference shown"), PREFIX.csv (one line
per gain, cell and metric) and, with --plot-gain (repeatable), PREFIX.png / .pdf: each such gain's
PSNR mean and seeds against the cell's training poses (the number in a cell name pN), one line per
gain and budget; a cell without pN (e.g. the novel-view cell) is a point with its std at the right.
Then each row the gains name, per cell, as mean +- std over its seeds. Then how each gain's PSNR
changes, paired by seed and read by the same rule ("rises" / "falls" when it does so on every
seed): from the fewest to the most training poses at each budget (cells pN), from the smallest to
the largest budget in each cell, and, for every --gain-change NAME=GAIN-BASE_GAIN, GAIN minus
BASE_GAIN in each cell (e.g. scs_tau003-scs: what a setting changes in a gain).
With --frames CAPTURE/frames.csv (handscs-synth's), each kept novel-pose run's per-image PSNRs are
also split as tools/study/frame_groups.py splits them, into held-out gestures some training pose moves to
and those none does; their gains appear beside the region PSNRs as gestures_seen / gestures_unseen.
Rows that failed or whose PSNR is not finite are left out and counted in the table. One seed has
no std: n/a in the table, empty in the CSV.
"""
import argparse
import csv
import json
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import frame_groups  # noqa: E402  (tools/study/frame_groups.py: the held-out gesture groups)
from seed_stats import mean_std, std_text  # noqa: E402  (one home for the mean and spread)

POINT = re.compile(r'^(?P<row>[A-Za-z0-9_-]+)(?:\.(?P<cell>[A-Za-z0-9_-]+))?\.s(?P<seed>\d+)$')
METRICS = ('psnr', 'ssim', 'lpips')


def number(text):
    try:
        v = float(text)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def novel_pose(folder, line):
    """Whether a kept run scored the held-out poses (its config.json: data.split_rule novel_pose and
    no data.validation_poses; a run folder without one is taken as such). Gesture groups split
    held-out poses: a novel-view run's test images show training poses, and so do a validation
    split's."""
    config = os.path.join(folder, 'runs', f'{line["point"]}_{line["budget"]}', 'config.json')
    if not os.path.exists(config):
        return True
    with open(config) as f:
        data = json.load(f).get('data') or {}
    return data.get('split_rule', 'novel_pose') == 'novel_pose' and not data.get('validation_poses')


def read_sweep(folder, gesture_groups=None):
    """{(row, cell, budget, seed): {metric: value}} of a sweep folder's finished rows (or of a
    results.csv file alone, as docs/bench keeps them: then the CSV's printed figures).
    gesture_groups: frame_groups.read_frames' map, to add each run's PSNR per gesture group."""
    path = folder if os.path.isfile(folder) else os.path.join(folder, 'results.csv')
    if not os.path.exists(path):
        sys.exit(f'{path}: no such file (not a handscs-bench output folder?)')
    results, left_out = {}, []
    with open(path, newline='') as f:
        for line in csv.DictReader(f):
            m = POINT.match(line.get('point', ''))
            if not m:
                sys.exit(f'{path}: point "{line.get("point")}" is not named <row>[.<cell>].s<seed>')
            key = (m['row'], m['cell'] or '-', int(line['budget']), int(m['seed']))
            values = {k: number(line.get(k)) for k in METRICS}
            if line.get('status') != 'ok' or values['psnr'] is None:
                left_out.append(f'{line["point"]}@{line["budget"]} ({line.get("status")})')
                continue
            summary = os.path.join(folder, 'runs', f'{line["point"]}_{line["budget"]}', 'eval',
                                   'summary.json')
            if os.path.exists(summary):
                with open(summary) as s:
                    report = json.load(s)
                # The run's own summary holds the CSV's figures at full precision: gains of a few
                # 1e-4 (LPIPS) are read from it, not from four printed decimals.
                for k in METRICS:
                    full = number((report.get('summary') or {}).get(k))
                    if full is not None:
                        values[k] = full
                # A region's PSNR of its pooled MSE: a region of a few pixels can match exactly in
                # one image, whose PSNR is then infinite, and so is the mean of per-image PSNRs.
                for name, region in (report.get('regions') or {}).items():
                    values[f'psnr_{name}'] = number(region.get('psnr_pooled_mse'))
            per_image = os.path.join(folder, 'runs', f'{line["point"]}_{line["budget"]}', 'eval',
                                     'per_image.csv')
            if gesture_groups and os.path.exists(per_image) and novel_pose(folder, line):
                scores, _ = frame_groups.score(gesture_groups, per_image)
                for group in frame_groups.GROUPS:
                    values[f'psnr_gestures_{group}'] = number(scores[group]['psnr'][0])
            results[key] = values
    return results, left_out


def reading(gains):
    if len(gains) < 2:
        return 'too few seeds'
    if all(g > 0 for g in gains):
        return 'pays'
    if all(g < 0 for g in gains):
        return 'costs'
    return 'no difference shown'


def row_means(results, gains, cells):
    """Markdown lines: each row the gains name, per cell, as mean +- std over its seeds."""
    rows = []
    for _, row, _, base, _ in gains:
        rows += [r for r in (row, base) if r not in rows]
    md = ['', '## The rows (mean +- std over their seeds)', '',
          '| row | cell | budget | seeds | PSNR (dB) | SSIM | LPIPS |', '|---|---|---|---|---|---|---|']
    for row in rows:
        for cell, budget in cells:
            runs = [v for (r, c, b, _), v in sorted(results.items()) if (r, c, b) == (row, cell, budget)]
            if not runs:
                continue
            cols = []
            for metric, digits in (('psnr', 3), ('ssim', 4), ('lpips', 4)):
                mean, std = mean_std([v[metric] for v in runs if v.get(metric) is not None])
                cols.append('' if mean is None else f'{mean:.{digits}f} +- {std_text(std, digits)}')
            md.append(f'| {row} | {cell} | {budget} | {len(runs)} | ' + ' | '.join(cols) + ' |')
    return md


def change_reading(changes):
    """The reading rule for a change of a gain: rises / falls on every seed."""
    return {'pays': 'rises', 'costs': 'falls', 'no difference shown': 'no change shown'}.get(
        reading(changes), reading(changes))


def poses_of(cell):
    m = re.search(r'p(\d+)', cell)
    return int(m.group(1)) if m else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('sweeps', nargs='+')
    parser.add_argument('--gain', action='append', required=True,
                        help='NAME=ROW-BASE, or NAME=ROW@BUDGET-BASE@BUDGET to pair two budgets')
    parser.add_argument('--out', required=True, help='output prefix (PREFIX.md, .csv, .png)')
    parser.add_argument('--gain-change', action='append', default=[],
                        help='NAME=GAIN-BASE_GAIN: one gain minus another, cell by cell')
    parser.add_argument('--plot-gain', action='append', default=[],
                        help='gain NAME to plot against training poses (repeatable)')
    parser.add_argument('--title', default='Paired gains')
    parser.add_argument('--frames',
                        help="handscs-synth's frames.csv: PSNR gains per gesture group too")
    args = parser.parse_args()

    gesture_groups = frame_groups.read_frames(args.frames) if args.frames else None
    results, left_out = {}, []
    for folder in args.sweeps:
        r, lo = read_sweep(folder, gesture_groups)
        results.update(r)
        left_out += lo
    gains = [parse_gain(spec) for spec in args.gain]
    names = [name for name, *_ in gains]
    if len(set(names)) < len(names):
        sys.exit(f'--gain: a name given twice ({", ".join(sorted({n for n in names if names.count(n) > 1}))}): '
                 'each gain needs its own')

    cells = sorted({(cell, budget) for (_, cell, budget, _) in results},
                   key=lambda c: (c[1], poses_of(c[0]) or 0, c[0]))
    metrics = sorted({k for v in results.values() for k in v},
                     key=lambda k: (k not in METRICS, METRICS.index(k) if k in METRICS else 0, k))
    rows_csv, md = [], [f'# {args.title}', '']
    md.append('| gain | cell | budget | seeds | PSNR (dB) | per seed | reading | SSIM | LPIPS | '
              'region (and gesture group) PSNRs |')
    md.append('|---|---|---|---|---|---|---|---|---|---|')
    plot = {}
    psnr_gains = {}  # (gain name, cell, budget) -> {seed: PSNR gain}
    for name, row, row_budget, base, base_budget in gains:
        for cell, budget, row_b, base_b in gain_cells(cells, row_budget, base_budget):
            seeds = sorted(s for (r, c, b, s) in results if r == row and c == cell and b == row_b
                           and (base, cell, base_b, s) in results)
            if not seeds:
                continue
            per_metric = {}
            for metric in metrics:
                values = [results[(row, cell, row_b, s)].get(metric) for s in seeds]
                bases = [results[(base, cell, base_b, s)].get(metric) for s in seeds]
                diffs = [v - b for v, b in zip(values, bases) if v is not None and b is not None]
                per_metric[metric] = diffs
                mean, std = mean_std(diffs)
                if mean is not None:
                    rows_csv.append([name, cell, budget, metric, len(diffs), f'{mean:.4f}',
                                     std_text(std, 4, missing=''), ' '.join(f'{d:+.4f}' for d in diffs)])
            psnr = per_metric['psnr']
            # Every row read has a finite PSNR (read_sweep leaves the others out): one gain a seed.
            psnr_gains[(name, cell, budget)] = dict(zip(seeds, psnr))
            mean, std = mean_std(psnr)
            ssim_m, ssim_s = mean_std(per_metric.get('ssim', []))
            lpips_m, lpips_s = mean_std(per_metric.get('lpips', []))
            # A region some runs do not score (no such pixels, or an older build) says on how many seeds.
            region_texts = []
            for k in metrics:
                if not (k.startswith('psnr_') and per_metric[k]):
                    continue
                region_mean, region_std = mean_std(per_metric[k])
                region_texts.append(f'{k[5:]} {region_mean:+.3f} +- {std_text(region_std, 3)}'
                                    + ('' if len(per_metric[k]) == len(psnr) else
                                       f' ({len(per_metric[k])} of {len(psnr)} seeds)'))
            regions = ', '.join(region_texts)
            md.append(f'| {name} ({at_budget(row, row_budget)} - {at_budget(base, base_budget)}) | {cell} | '
                      f'{budget} | {len(psnr)} | '
                      f'{mean:+.3f} +- {std_text(std, 3)} | {" / ".join(f"{d:+.3f}" for d in psnr)} | '
                      f'{reading(psnr)} | '
                      + (f'{ssim_m:+.4f} +- {std_text(ssim_s, 4)}' if ssim_m is not None else '') + ' | '
                      + (f'{lpips_m:+.4f} +- {std_text(lpips_s, 4)}' if lpips_m is not None else '')
                      + f' | {regions} |')
            if name in args.plot_gain:
                plot.setdefault((name, budget), []).append((cell, psnr))
    md += row_means(results, gains, cells)
    changes = gain_changes(psnr_gains, gains, args.gain_change)
    if changes:
        md += ['', '## How the gains change (PSNR, paired by seed)', '',
               '| change | seeds | PSNR (dB) | per seed | reading |', '|---|---|---|---|---|']
        for label, diffs in changes:
            mean, std = mean_std(diffs)
            md.append(f'| {label} | {len(diffs)} | {mean:+.3f} +- {std_text(std, 3)} | '
                      f'{" / ".join(f"{d:+.3f}" for d in diffs)} | {change_reading(diffs)} |')
            rows_csv.append([label, '', '', 'psnr_change', len(diffs), f'{mean:.4f}', std_text(std, 4, missing=''),
                             ' '.join(f'{d:+.4f}' for d in diffs)])
    if left_out:
        md += ['', f'Left out ({len(left_out)}): ' + ', '.join(left_out)]
    with open(args.out + '.md', 'w') as f:
        f.write('\n'.join(md) + '\n')
    with open(args.out + '.csv', 'w', newline='') as f:
        w = csv.writer(f, lineterminator='\n')
        w.writerow(['gain', 'cell', 'budget', 'metric', 'seeds', 'mean', 'std', 'per_seed'])
        w.writerows(rows_csv)
    print('\n'.join(md))
    if args.plot_gain and plot:
        draw(plot, args)


def paired(a, b):
    """b - a for the seeds both {seed: value} maps hold, in seed order."""
    return [b[s] - a[s] for s in sorted(a) if s in b]


def parse_gain(spec):
    """(name, row, row budget, base, base budget) of --gain NAME=ROW-BASE (budgets None: both rows at
    each cell's own budget) or NAME=ROW@B1-BASE@B2."""
    m = re.match(r'^([A-Za-z0-9_]+)=([A-Za-z0-9_-]+)@(\d+)-([A-Za-z0-9_-]+)@(\d+)$', spec)
    if m:
        name, row, row_budget, base, base_budget = m.groups()
        return name, row, int(row_budget), base, int(base_budget)
    m = re.match(r'^([A-Za-z0-9_]+)=([A-Za-z0-9_-]+)-([A-Za-z0-9_-]+)$', spec)
    if not m:
        sys.exit(f'--gain {spec}: expected NAME=ROW-BASE or NAME=ROW@BUDGET-BASE@BUDGET')
    name, row, base = m.groups()
    return name, row, None, base, None


def at_budget(row, budget):
    """A gain's row as its table names it: ROW, or ROW@BUDGET when the gain pairs two budgets."""
    return row if budget is None else f'{row}@{budget}'


def gain_cells(cells, row_budget, base_budget):
    """[(cell, budget label, row's budget, base's budget)] a gain reads: every (cell, budget), or,
    with budgets of its own, every cell name once, labelled "B1 vs B2"."""
    if row_budget is None:
        return [(cell, budget, budget, budget) for cell, budget in cells]
    names = list(dict.fromkeys(cell for cell, _ in cells))
    return [(cell, f'{row_budget} vs {base_budget}', row_budget, base_budget) for cell in names]


def gain_changes(psnr_gains, gains, specs):
    """[(label, per-seed changes)]: each gain from the fewest to the most training poses per budget,
    from the smallest to the largest budget per cell, and each --gain-change GAIN-BASE per cell."""
    out = []
    for name, *_ in gains:
        mine = {(c, b): v for (n, c, b), v in psnr_gains.items() if n == name}
        for budget in sorted({b for _, b in mine}):
            posed = sorted((poses_of(c), c) for c, b in mine if b == budget and poses_of(c) is not None)
            if len(posed) > 1 and posed[0][0] != posed[-1][0]:
                (_, few), (_, many) = posed[0], posed[-1]
                diffs = paired(mine[(few, budget)], mine[(many, budget)])
                if diffs:
                    out.append((f'{name}: {many} - {few}, {budget} steps', diffs))
        for cell in sorted({c for c, _ in mine}):
            budgets = sorted(b for c, b in mine if c == cell)
            if len(budgets) > 1:
                diffs = paired(mine[(cell, budgets[0])], mine[(cell, budgets[-1])])
                if diffs:
                    out.append((f'{name}: {budgets[-1]} - {budgets[0]} steps, {cell}', diffs))
    for spec in specs:
        m = re.match(r'^([A-Za-z0-9_]+)=([A-Za-z0-9_]+)-([A-Za-z0-9_]+)$', spec)
        if not m:
            sys.exit(f'--gain-change {spec}: expected NAME=GAIN-BASE_GAIN')
        label, gain, base = m.groups()
        for (n, cell, budget), values in sorted(psnr_gains.items()):
            if n == gain and (base, cell, budget) in psnr_gains:
                diffs = paired(psnr_gains[(base, cell, budget)], values)
                if diffs:
                    out.append((f'{label} ({gain} - {base}): {cell}, {budget} steps', diffs))
    return out


def draw(plot, args):
    try:
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
    except ImportError:
        print('paired_gains.py: matplotlib is missing (python3-matplotlib): no plot', file=sys.stderr)
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for (name, budget), cells in sorted(plot.items()):
        points = sorted((poses_of(c), g, c) for c, g in cells if poses_of(c) is not None)
        others = [(c, g) for c, g in cells if poses_of(c) is None]
        if points:
            xs = [p for p, _, _ in points]
            line, = ax.plot(xs, [mean_std(g)[0] for _, g, _ in points], marker='o',
                            label=f'{name}, {budget} steps')
            for p, g, _ in points:  # each seed, in its line's colour
                ax.scatter([p] * len(g), g, s=12, color=line.get_color(), alpha=0.5, zorder=3)
        for c, g in others:
            g_mean, g_std = mean_std(g)
            ax.errorbar([max([p for p, _, _ in points], default=0) * 1.15 + 10],
                        [g_mean], yerr=[g_std or 0],
                        fmt='s', label=f'{name}: {c}, {budget} steps')
    ax.axhline(0, color='black', linewidth=0.8)
    ax.set_xlabel('training poses')
    ax.set_ylabel('gain, PSNR (dB)')
    ax.set_title(args.title)
    ax.legend()
    fig.tight_layout()
    for ext in ('png', 'pdf'):
        fig.savefig(f'{args.out}.{ext}', dpi=120)


if __name__ == '__main__':
    main()
