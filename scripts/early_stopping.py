#!/usr/bin/python3
"""Early stopping on a validation split of the training poses, for the runs a sweep kept.

    /usr/bin/python3 scripts/early_stopping.py SWEEP_OUT... --out OUT [--lpips-weights W]
        [--bin build/bin] [--threads 1] [--set KEY=VALUE ...]

Each SWEEP_OUT is a handscs-bench output folder (results.csv, runs/<point>_<budget>/) whose runs
trained on the novel-pose split with data.validation_poses > 0 (the last N training poses held out
as validation, the capture's test poses unopened) and kept every checkpoint
(train.keep_checkpoints=0). Point names are <row>.<cell>.s<seed>, as scripts/paired_gains.py reads
them. For every such run:
  1. each checkpoint is scored on the validation poses (handscs-eval: PSNR and SSIM of every
     validation image, no LPIPS, no regions) into RUN/early_stopping/validation_<step>/; a second
     call scores only what is missing;
  2. the checkpoint of the highest validation PSNR is chosen, the earliest of equal ones; a
     checkpoint whose PSNR is not finite is never chosen;
  3. the chosen checkpoint and the last one are scored on the capture's held-out test poses
     (data.validation_poses=0: every test image, LPIPS with --lpips-weights, the capture's region
     masks) into OUT/runs/<row>_es.<cell>.s<seed>_<budget>/eval/ and
     OUT/runs/<row>_end.<cell>.s<seed>_<budget>/eval/.
Writes OUT/results.csv (point, budget, status, step, validation_psnr, eval_images, psnr, ssim, lpips;
rows <row>_es and <row>_end, which scripts/paired_gains.py reads like a sweep's), OUT/validation.csv
(point, budget, step, psnr, ssim of every checkpoint) and, with Debian's python3-matplotlib,
OUT/validation.png / .pdf: validation PSNR against step, one line per run, its choice marked.
--set passes config keys to every handscs-eval call (e.g. data.root=DIR when the capture moved).
"""
import argparse
import csv
import json
import os
import re
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from paired_gains import POINT, number  # noqa: E402  (one home for the point names and numbers)

CHECKPOINT = re.compile(r'^step_(\d+)\.ckpt$')
RESULT_COLUMNS = ('point', 'budget', 'status', 'step', 'validation_psnr', 'eval_images', 'psnr', 'ssim',
                  'lpips')


def kept_summary(out, checkpoint):
    """The figures of an earlier score of `checkpoint` in `out`, None when there is none (or it
    scored another checkpoint)."""
    path = os.path.join(out, 'summary.json')
    if not os.path.exists(path):
        return None
    with open(path) as f:
        report = json.load(f)
    scored = (report.get('inputs') or {}).get('checkpoint')
    return report.get('summary') if scored and os.path.abspath(scored) == checkpoint else None


def run_eval(args, checkpoint, out, options, sets):
    """Scores one checkpoint with handscs-eval into `out` (an earlier score of the same checkpoint
    there is kept): the summary's figures. `options` are more handscs-eval options, `sets` config
    keys beside --set's."""
    checkpoint = os.path.abspath(checkpoint)
    kept = kept_summary(out, checkpoint)
    if kept is not None:
        return kept
    os.makedirs(os.path.dirname(out), exist_ok=True)
    command = [os.path.join(args.bin, 'handscs-eval'), '--checkpoint', checkpoint, '--out', out,
               '--threads', str(args.threads), '--log-level', 'warn'] + options
    if args.set or sets:
        command += ['--set'] + list(args.set) + sets
    log = out + '.log'
    with open(log, 'w') as f:
        done = subprocess.run(command, stdout=f, stderr=subprocess.STDOUT)
    summary = kept_summary(out, checkpoint)
    if done.returncode != 0 or summary is None:
        with open(log) as f:
            tail = f.read().splitlines()[-3:]
        sys.exit(f'early_stopping: handscs-eval failed on {checkpoint}; the end of {log}:\n' +
                 '\n'.join(tail))
    return summary


def checkpoints_of(run):
    """[(step, path)] of a run folder's checkpoints, by step."""
    folder = os.path.join(run, 'checkpoints')
    found = []
    for name in os.listdir(folder) if os.path.isdir(folder) else []:
        m = CHECKPOINT.match(name)
        if m:
            found.append((int(m.group(1)), os.path.join(folder, name)))
    return sorted(found)


def validation_poses_of(run):
    """data.validation_poses of the config a run trained with (0 when it has none)."""
    with open(os.path.join(run, 'config.json')) as f:
        config = json.load(f)
    return int((config.get('data') or {}).get('validation_poses', 0))


def choose(scores):
    """The step of the highest finite validation PSNR, the earliest of equal ones; None if none is
    finite. scores: [(step, psnr or None)] by step."""
    best = None
    for step, psnr in scores:
        if psnr is not None and (best is None or psnr > best[1]):
            best = (step, psnr)
    return best


def runs_of(sweeps):
    """[(sweep, point, budget, run folder)] of the sweeps' finished, kept runs."""
    runs = []
    for sweep in sweeps:
        path = os.path.join(sweep, 'results.csv')
        if not os.path.exists(path):
            sys.exit(f'{path}: no such file (not a handscs-bench output folder?)')
        with open(path, newline='') as f:
            for line in csv.DictReader(f):
                point, budget = line.get('point', ''), line.get('budget', '')
                if not POINT.match(point):
                    sys.exit(f'{path}: point "{point}" is not named <row>[.<cell>].s<seed>')
                run = os.path.join(sweep, 'runs', f'{point}_{budget}')
                if line.get('status') == 'ok' and os.path.isdir(run):
                    runs.append((sweep, point, int(budget), run))
    return runs


def renamed(point, suffix):
    """<row>.<cell>.s<seed> with <row> + suffix."""
    m = POINT.match(point)
    return m['row'] + suffix + point[len(m['row']):]


def figure(value, digits):
    return '' if value is None else f'{value:.{digits}f}'


def plot(out, curves):
    try:  # the curves, when Debian's matplotlib is there (python3-matplotlib)
        import matplotlib
        matplotlib.use('Agg')
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for point, scores, best in curves:
        steps = [s for s, p in scores if p is not None]
        line, = ax.plot(steps, [p for _, p in scores if p is not None], '-', lw=1.2, label=point)
        if best:
            ax.plot([best[0]], [best[1]], 'o', ms=6, color=line.get_color())
    ax.set(xlabel='training step', ylabel='validation PSNR (dB)',
           title='Validation PSNR per checkpoint (dot: the checkpoint chosen)')
    ax.legend(fontsize=7)
    fig.tight_layout()
    for ext in ('png', 'pdf'):
        fig.savefig(os.path.join(out, f'validation.{ext}'), dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('sweeps', nargs='+')
    parser.add_argument('--out', required=True)
    parser.add_argument('--lpips-weights', help='LPIPS weight file for the test scores (without it LPIPS is empty)')
    parser.add_argument('--bin', default=os.path.join(os.path.dirname(os.path.abspath(__file__)), '..',
                                                     'build', 'bin'), help='folder of handscs-eval')
    parser.add_argument('--threads', type=int, default=1, help='threads of each handscs-eval')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='a config key for every handscs-eval (repeatable)')
    args = parser.parse_args()
    if not os.path.exists(os.path.join(args.bin, 'handscs-eval')):
        sys.exit(f'early_stopping: {args.bin}/handscs-eval: no such program (--bin)')
    if args.lpips_weights and not os.path.exists(args.lpips_weights):
        sys.exit(f'early_stopping: {args.lpips_weights}: no such file (--lpips-weights)')

    runs = []
    for sweep, point, budget, run in runs_of(args.sweeps):
        if validation_poses_of(run) <= 0:
            print(f'early_stopping: {run}: trained without data.validation_poses; left out', file=sys.stderr)
        elif not checkpoints_of(run):
            print(f'early_stopping: {run}: no checkpoints; left out', file=sys.stderr)
        else:
            runs.append((point, budget, run))
    if not runs:
        sys.exit('early_stopping: no kept run trained with validation poses and checkpoints')

    os.makedirs(args.out, exist_ok=True)
    test_options = ['--lpips-weights', args.lpips_weights] if args.lpips_weights else []
    results, validation, curves = [], [], []
    for point, budget, run in runs:
        checkpoints = checkpoints_of(run)
        scores = []
        for step, checkpoint in checkpoints:
            print(f'early_stopping: {point}@{budget}: validation, step {step}', file=sys.stderr)
            s = run_eval(args, checkpoint, os.path.join(run, 'early_stopping', f'validation_{step}'),
                         ['--no-regions'], [])
            scores.append((step, number(s.get('psnr'))))
            validation.append([point, budget, step, figure(number(s.get('psnr')), 4),
                               figure(number(s.get('ssim')), 5)])
        best = choose(scores)
        curves.append((point, scores, best))
        last_step, last = checkpoints[-1]
        picks = [('_es', best[0] if best else None, best[1] if best else None),
                 ('_end', last_step, dict(scores)[last_step])]
        tested = {}  # step: (checkpoint, its test folder), so one checkpoint chosen twice is scored once
        for suffix, step, validation_psnr in picks:
            name = renamed(point, suffix)
            row = {'point': name, 'budget': budget, 'step': '' if step is None else step,
                   'validation_psnr': figure(validation_psnr, 4)}
            if step is None:
                row['status'] = 'no_finite_validation'
            else:
                target = os.path.join(args.out, 'runs', f'{name}_{budget}', 'eval')
                if step in tested and kept_summary(target, tested[step][0]) is None:
                    shutil.copytree(tested[step][1], target, dirs_exist_ok=True)  # the same checkpoint
                print(f'early_stopping: {name}@{budget}: test, step {step}', file=sys.stderr)
                s = run_eval(args, dict(checkpoints)[step], target, test_options, ['data.validation_poses=0'])
                tested[step] = (os.path.abspath(dict(checkpoints)[step]), target)
                row.update({'status': 'ok', 'eval_images': figure(number(s.get('scored')), 0),
                            'psnr': figure(number(s.get('psnr')), 4), 'ssim': figure(number(s.get('ssim')), 5),
                            'lpips': figure(number(s.get('lpips')), 5)})
            results.append(row)

    with open(os.path.join(args.out, 'results.csv'), 'w', newline='') as f:
        writer = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
        writer.writeheader()
        writer.writerows(results)
    with open(os.path.join(args.out, 'validation.csv'), 'w', newline='') as f:
        writer = csv.writer(f)
        writer.writerow(['point', 'budget', 'step', 'psnr', 'ssim'])
        writer.writerows(validation)
    plot(args.out, curves)
    for row in results:
        print(json.dumps(row))


if __name__ == '__main__':
    main()
