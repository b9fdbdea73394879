#!/usr/bin/python3
"""Early stopping on a validation split of the training poses or cameras, for the runs a sweep kept.

    /usr/bin/python3 tools/study/early_stopping.py SWEEP_OUT... --out OUT [--lpips-weights W]
        [--bin build/bin] [--threads 1] [--set KEY=VALUE] [--set KEY=VALUE] ...

Each SWEEP_OUT is a handscs-bench output folder (results.csv, runs/<point>_<budget>/) whose runs
trained with a validation split, data.validation_poses > 0 on the novel-pose split (the last N
training poses held out as validation, the capture's test poses unopened) or data.validation_cameras
on the novel-view split (those training cameras held out, the test cameras unopened), and kept
every checkpoint (train.keep_checkpoints=0) up to the budget; other runs are named and left out.
Point names are <row>.<cell>.s<seed>, as tools/study/paired_gains.py reads them. For every such run:
  1. each checkpoint is scored on the validation split (handscs-eval: PSNR and SSIM of every
     validation image, no LPIPS, no regions) into RUN/early_stopping/validation_<step>/; a second
     call scores again only what is missing or was scored by another command or checkpoint file;
  2. the checkpoint of the highest validation PSNR is chosen, the earliest of equal ones; a
     checkpoint whose PSNR is not finite is never chosen;
  3. the chosen checkpoint and the last one are scored on the capture's test split
     (data.validation_poses=0 or data.validation_cameras=[], whichever the run set: every test
     image, LPIPS with --lpips-weights or the run's weights, the capture's region masks) into
     OUT/runs/<row>_es.<cell>.s<seed>_<budget>/eval/ and OUT/runs/<row>_end.<cell>.s<seed>_<budget>/eval/.
Writes OUT/results.csv (point, budget, status, step, validation_psnr, eval_images, psnr, ssim, lpips;
rows <row>_es and <row>_end, which tools/study/paired_gains.py reads like a sweep's), OUT/validation.csv
(point, budget, step, psnr, ssim of every checkpoint) and, with Debian's python3-matplotlib,
OUT/validation.png / .pdf: validation PSNR against step, one line per run, its choice marked.
--set passes a config key to every handscs-eval call (repeatable; e.g. data.root=DIR when the
capture moved).
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


def read_json(path):
    """A JSON file's content; a file that is not JSON stops the script, naming it."""
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f'early_stopping: {path}: cannot read ({e})')


def stamp(path):
    """Size and modification time of a file: a retrained checkpoint at the same path differs."""
    info = os.stat(path)
    return [info.st_size, info.st_mtime_ns]


def eval_key(command, checkpoint):
    """What decides a score: the handscs-eval command without its output folder, and the stamps of
    the program and the checkpoint. An earlier score is reused only when its key is this one."""
    at = command.index('--out')
    return {'command': command[:at] + command[at + 2:], 'program': stamp(command[0]),
            'checkpoint': stamp(checkpoint)}


def figures_of(out):
    """The summary figures handscs-eval wrote into `out`; a summary without them stops the script,
    naming it."""
    path = os.path.join(out, 'summary.json')
    figures = read_json(path).get('summary')
    if not isinstance(figures, dict):
        sys.exit(f'early_stopping: {path}: no "summary" object (not a handscs-eval summary?)')
    return figures


def kept_summary(out, key):
    """The figures of an earlier score in `out` made with `key`, else None."""
    summary, kept = os.path.join(out, 'summary.json'), out + '.key.json'
    if not (os.path.exists(summary) and os.path.exists(kept)) or read_json(kept) != key:
        return None
    return figures_of(out)


def forget(out):
    """Removes an earlier score in `out` (its folder, key and log), so that a score cut short never
    sits beside an older key."""
    for path in (out + '.key.json', out + '.log'):
        if os.path.exists(path):
            os.remove(path)
    shutil.rmtree(out, ignore_errors=True)


def run_eval(args, checkpoint, out, options, sets, copy_from=None):
    """Scores one checkpoint with handscs-eval into `out`, or copies the score in `copy_from` when it
    was made with the same key (one checkpoint chosen twice is scored once), or keeps an earlier
    score in `out` made with it: the summary's figures. `options` are more handscs-eval options,
    `sets` config keys after --set's."""
    checkpoint = os.path.abspath(checkpoint)
    command = [os.path.join(args.bin, 'handscs-eval'), '--checkpoint', checkpoint, '--out', out,
               '--threads', str(args.threads), '--log-level', 'warn'] + options
    if args.set or sets:
        command += ['--set'] + list(args.set) + sets
    key = eval_key(command, checkpoint)
    kept = kept_summary(out, key)
    if kept is not None:
        return kept
    forget(out)
    if copy_from is not None and kept_summary(copy_from, key) is not None:
        shutil.copytree(copy_from, out)
    else:
        os.makedirs(os.path.dirname(out), exist_ok=True)
        log = out + '.log'
        with open(log, 'w') as f:
            done = subprocess.run(command, stdout=f, stderr=subprocess.STDOUT)
        if done.returncode != 0 or not os.path.exists(os.path.join(out, 'summary.json')):
            with open(log) as f:
                tail = f.read().splitlines()[-3:]
            sys.exit(f'early_stopping: handscs-eval failed on {checkpoint}; the end of {log}:\n' +
                     '\n'.join(tail))
    figures = figures_of(out)
    with open(out + '.key.json.tmp', 'w') as f:
        json.dump(key, f)
    os.replace(out + '.key.json.tmp', out + '.key.json')  # the key last, and whole
    return figures


def checkpoints_of(run):
    """[(step, path)] of a run folder's checkpoints, by step."""
    folder = os.path.join(run, 'checkpoints')
    found = []
    for name in os.listdir(folder) if os.path.isdir(folder) else []:
        m = CHECKPOINT.match(name)
        if m:
            found.append((int(m.group(1)), os.path.join(folder, name)))
    return sorted(found)


def test_split(config):
    """The config keys that turn a run's validation split back into the capture's test split
    (config: the run's config.json): data.validation_poses=0 (novel pose) and
    data.validation_cameras=[] (novel view), each only when the run set it (a build that predates a
    key refuses it). Empty: no validation split."""
    data = config.get('data') or {}
    keys = []
    if int(data.get('validation_poses', 0)) > 0:
        keys.append('data.validation_poses=0')
    if data.get('validation_cameras'):
        keys.append('data.validation_cameras=[]')
    return keys


def unusable(config, budget, checkpoints):
    """Why a kept run cannot stop early ('' when it can): no validation split, not every checkpoint
    kept, or no checkpoint at its budget. config: its config.json; checkpoints: checkpoints_of(run)."""
    if not test_split(config):
        return 'trained without data.validation_poses or data.validation_cameras'
    kept = (config.get('train') or {}).get('keep_checkpoints')
    if kept is None:  # builds before the key kept the newest two
        return 'its config has no train.keep_checkpoints (a build that kept only the newest two checkpoints)'
    if int(kept) != 0:
        return f'kept only its newest {kept} checkpoints (train.keep_checkpoints; early stopping needs 0, all)'
    if not checkpoints or checkpoints[-1][0] != budget:
        last = checkpoints[-1][0] if checkpoints else 'none'
        return f'its last checkpoint is step {last}, not its budget {budget}'
    return ''


def choose(scores):
    """The step of the highest finite validation PSNR, the earliest of equal ones; None if none is
    finite. scores: [(step, psnr or None)] by step."""
    best = None
    for step, psnr in scores:
        if psnr is not None and (best is None or psnr > best[1]):
            best = (step, psnr)
    return best


def runs_of(sweeps):
    """[(point, budget, run folder)] of the sweeps' finished runs; a finished run whose folder the
    sweep did not keep is named and left out."""
    runs = []
    for sweep in sweeps:
        path = os.path.join(sweep, 'results.csv')
        if not os.path.exists(path):
            sys.exit(f'early_stopping: {path}: no such file (not a handscs-bench output folder?)')
        with open(path, newline='') as f:
            for line in csv.DictReader(f):
                point, budget = line.get('point', ''), line.get('budget', '')
                if not POINT.match(point) or not budget.isdigit():
                    sys.exit(f'early_stopping: {path}: point "{point}" at budget "{budget}" is not '
                             '<row>[.<cell>].s<seed> at a whole number of steps')
                if line.get('status') != 'ok':
                    continue
                run = os.path.join(sweep, 'runs', f'{point}_{budget}')
                if os.path.isdir(run):
                    runs.append((point, int(budget), run))
                else:
                    print(f'early_stopping: {run}: not kept (handscs-bench without --keep-runs?); left out',
                          file=sys.stderr)
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
    parser.add_argument('--lpips-weights', help="LPIPS weight file for the test scores (without it, the run's own)")
    parser.add_argument('--bin', default=os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..',
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
    for point, budget, run in runs_of(args.sweeps):
        checkpoints = checkpoints_of(run)
        config = read_json(os.path.join(run, 'config.json'))
        why = unusable(config, budget, checkpoints)
        if why:
            print(f'early_stopping: {run}: {why}; left out', file=sys.stderr)
        else:
            runs.append((point, budget, run, checkpoints, test_split(config)))
    if not runs:
        sys.exit('early_stopping: no kept run trained with a validation split and every checkpoint')

    os.makedirs(args.out, exist_ok=True)
    test_options = ['--lpips-weights', args.lpips_weights] if args.lpips_weights else []
    results, validation, curves = [], [], []
    for point, budget, run, checkpoints, restore_test in runs:
        scores = []
        for step, checkpoint in checkpoints:
            print(f'early_stopping: {point}@{budget}: validation, step {step}', file=sys.stderr)
            # PSNR chooses: no LPIPS (an empty weight file overrides the run's) and no regions.
            s = run_eval(args, checkpoint, os.path.join(run, 'early_stopping', f'validation_{step}'),
                         ['--no-regions'], ['eval.lpips.weights='])
            scores.append((step, number(s.get('psnr'))))
            validation.append([point, budget, step, figure(number(s.get('psnr')), 4),
                               figure(number(s.get('ssim')), 5)])
        best = choose(scores)
        curves.append((point, scores, best))
        checkpoint_at = dict(checkpoints)
        last_step = checkpoints[-1][0]
        picks = [('_es', best[0] if best else None, best[1] if best else None),
                 ('_end', last_step, scores[-1][1])]
        tested = {}  # step: its test folder, so one checkpoint chosen twice is scored once
        for suffix, step, validation_psnr in picks:
            name = renamed(point, suffix)
            row = {'point': name, 'budget': budget, 'step': '' if step is None else step,
                   'validation_psnr': figure(validation_psnr, 4)}
            if step is None:
                row['status'] = 'no_finite_validation'
            else:
                target = os.path.join(args.out, 'runs', f'{name}_{budget}', 'eval')
                print(f'early_stopping: {name}@{budget}: test, step {step}', file=sys.stderr)
                s = run_eval(args, checkpoint_at[step], target, test_options, restore_test,
                             copy_from=tested.get(step))
                tested[step] = target
                row.update({'status': 'ok', 'eval_images': figure(number(s.get('scored')), 0),
                            'psnr': figure(number(s.get('psnr')), 4), 'ssim': figure(number(s.get('ssim')), 5),
                            'lpips': figure(number(s.get('lpips')), 5)})
            results.append(row)

    with open(os.path.join(args.out, 'results.csv'), 'w', newline='') as f:
        writer = csv.DictWriter(f, fieldnames=RESULT_COLUMNS, lineterminator='\n')
        writer.writeheader()
        writer.writerows(results)
    with open(os.path.join(args.out, 'validation.csv'), 'w', newline='') as f:
        writer = csv.writer(f, lineterminator='\n')
        writer.writerow(['point', 'budget', 'step', 'psnr', 'ssim'])
        writer.writerows(validation)
    plot(args.out, curves)
    for row in results:
        print(json.dumps(row))


if __name__ == '__main__':
    main()
