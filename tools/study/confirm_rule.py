#!/usr/bin/python3
"""The open choices' confirmation rule (docs/SCALING.md), read from the confirmation's sweeps.

    /usr/bin/python3 tools/study/confirm_rule.py --capture real_demo=OUT1[,OUT1b] --capture seed2=OUT2 \
        [--base default] [--cell full] [--general-cell c] [--out PREFIX]

Each OUT is a handscs-bench output folder of configs/sweeps/open_choices_confirm.json or of a sweep
run on the same capture beside it (open_choices_pair.json), comma-separated; points are named
<variant>.<cell>.s<seed>, e.g. tau003.full.s13. For every variant row other than --base, on the
--cell rows: the PSNR gain over the base paired by seed, per capture, and the rule as declared
before the runs: a default changes only if, on every capture, the mean PSNR gain is at least
+0.05 dB and the mean LPIPS is not worse by more than 0.001, and the gain is positive on all pairs
but at most one (5 of 6 for two captures of three seeds). A variant that also has --general-cell
rows is a general change, not an SCS gain, when its mean gain there is at least half its mean gain
on --cell. Full-precision means are read from the kept runs' summaries (paired_gains.read_sweep).
No verdict is given before every capture has --seeds pairs. Writes PREFIX.md with the table and
each verdict, and prints it.
"""
import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from paired_gains import read_sweep  # noqa: E402

# The rule's thresholds, fixed in docs/SCALING.md before the confirmation ran.
MIN_MEAN_PSNR_GAIN_DB = 0.05    # a mean gain below this is within seed noise on these captures
MAX_LPIPS_WORSENING = 0.001     # a PSNR gain may not be bought with a visible perceptual loss
PAIRS_ALLOWED_TO_LOSE = 1       # 5 of 6 (capture, seed) pairs must gain
GENERAL_FRACTION = 0.5          # (c) gaining half as much as the full model: not SCS's own gain


def paired(results, row, base, cell, metric):
    """{seed: row - base} for the seeds both rows finished in the cell with the metric (LPIPS is
    missing from runs scored without its weights)."""
    rows = {(r, c, s): v for (r, c, _budget, s), v in results.items()}
    seeds = sorted(s for (r, c, s) in rows if r == row and c == cell and (base, cell, s) in rows)
    pairs = {s: (rows[(row, cell, s)].get(metric), rows[(base, cell, s)].get(metric)) for s in seeds}
    return {s: a - b for s, (a, b) in pairs.items() if a is not None and b is not None}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--capture', action='append', required=True, help='LABEL=SWEEP_OUT[,SWEEP_OUT]')
    ap.add_argument('--base', default='default')
    ap.add_argument('--cell', default='full')
    ap.add_argument('--general-cell', default='c')
    ap.add_argument('--seeds', type=int, default=3, help='seeds each capture must have for a verdict')
    ap.add_argument('--out')
    args = ap.parse_args()

    captures = []
    for item in args.capture:
        label, sep, folders = item.partition('=')
        if not sep or not folders:
            sys.exit(f'--capture {item}: expected LABEL=SWEEP_OUT[,SWEEP_OUT]')
        results = {}
        for folder in folders.split(','):
            found, left_out = read_sweep(folder)
            if left_out:
                print(f'{folder}: left out (failed or not finite): {", ".join(left_out)}',
                      file=sys.stderr)
            twice = sorted(set(found) & set(results))
            if twice:
                sys.exit(f'{folder}: {twice[0]} is also in an earlier folder of {label}')
            results.update(found)
        captures.append((label, results))

    variants = sorted({r for _, res in captures for (r, c, _b, _s) in res
                       if c == args.cell and r != args.base})
    lines = ['| variant | ' + ' | '.join(f'{label}: PSNR gain per seed (mean) | {label}: LPIPS change'
                                         for label, _ in captures) + ' | pairs better | verdict |',
             '|---|' + '---|---|' * len(captures) + '---|---|']
    for variant in variants:
        cells, gains_all, verdict_fails, incomplete = [], [], [], []
        for label, res in captures:
            psnr = paired(res, variant, args.base, args.cell, 'psnr')
            lpips = paired(res, variant, args.base, args.cell, 'lpips')
            if len(psnr) < args.seeds:
                incomplete.append(f'{len(psnr)} of {args.seeds} seeds on {label}')
            if not psnr:
                cells += ['not run', '-']
                continue
            mean = statistics.fmean(psnr.values())
            if len(lpips) < len(psnr):
                incomplete.append(f'LPIPS on {len(lpips)} of {len(psnr)} seeds on {label}')
            lp = statistics.fmean(lpips.values()) if lpips else float('nan')
            gains_all += psnr.values()
            per_seed = ' / '.join(f'{g:+.3f}' for _, g in sorted(psnr.items()))
            cells += [f'{per_seed} ({mean:+.3f})', f'{lp:+.5f}']
            if mean < MIN_MEAN_PSNR_GAIN_DB:
                verdict_fails.append(f'mean gain {mean:+.3f} dB on {label}')
            if lp > MAX_LPIPS_WORSENING:
                verdict_fails.append(f'LPIPS worse by {lp:.5f} on {label}')
        better = sum(g > 0 for g in gains_all)
        if better < len(gains_all) - PAIRS_ALLOWED_TO_LOSE:
            verdict_fails.append(f'gains on {better} of {len(gains_all)} pairs')
        if incomplete:
            verdict = 'not read yet: ' + '; '.join(incomplete)
        elif verdict_fails:
            verdict = 'keeps the default: ' + '; '.join(verdict_fails)
        else:
            verdict = 'changes the default'
        general = []
        for label, res in captures:
            general += paired(res, variant, args.base, args.general_cell, 'psnr').values()
        if general and gains_all:
            g_mean, f_mean = statistics.fmean(general), statistics.fmean(gains_all)
            kind = ('a general change' if g_mean >= GENERAL_FRACTION * f_mean else "SCS's gain")
            verdict += (f'; on ({args.general_cell}) {g_mean:+.3f} dB against {f_mean:+.3f} on '
                        f'{args.cell}: {kind}')
        lines.append(f'| `{variant}` | ' + ' | '.join(cells) +
                     f' | {better} of {len(gains_all)} | {verdict} |')
    text = '\n'.join(lines) + '\n'
    print(text, end='')
    if args.out:
        with open(args.out + '.md', 'w') as f:
            f.write(text)


if __name__ == '__main__':
    main()
