#!/usr/bin/python3
"""Held-out scores split by what the pose is: a gesture some training pose moves to, or one none does.

    /usr/bin/python3 tools/study/frame_groups.py CAPTURE/frames.csv RUN_OR_CSV... [--csv OUT.csv]

CAPTURE/frames.csv is written by handscs-synth (one row per pose: sequence, frame index, held out,
the gesture the hand moves to, whether any training pose moves to that gesture). Its held-out rows
are the poses a run holds out when data.held_out_poses equals the generator's held_out_frames and
frame_stride is 1; a scored image of any other pose is an error. Each further argument is a
handscs-eval per_image.csv, a run folder (RUN/eval/per_image.csv) or a handscs-bench sweep folder
(every SWEEP/runs/*/eval/per_image.csv). Prints one Markdown row per run: images, PSNR, SSIM and
LPIPS of the held-out images of gestures training saw ("seen") and of those it never saw
("unseen"). A metric value that is missing, not finite, or of an image that failed is left out of
its mean and counted in "values left out" (unlike handscs-eval, a partial LPIPS mean is printed).
"""
import csv
import math
import os
import re
import sys

GROUPS = ('seen', 'unseen')
METRICS = ('psnr', 'ssim', 'lpips')
# handscs-eval's image names: <capture>/<sequence>/cam<id>/image<frame>.jpg
NAME = re.compile(r'^[^/]+/([^/]+)/[^/]+/image(\d+)\.\w+$')


def read_frames(path):
    groups = {}
    with open(path, newline='') as f:
        for row in csv.DictReader(f):
            missing = [c for c in ('seq_name', 'frame_idx', 'held_out', 'gesture_in_training') if c not in row]
            if missing:
                sys.exit(f'{path}: no column {missing[0]} (not a handscs-synth frames.csv?)')
            if row['held_out'] != '1':
                continue
            if row['gesture_in_training'] not in ('0', '1'):
                sys.exit(f'{path}: frame {row["frame_idx"]} has no gesture label (not a gesture capture?)')
            groups[(row['seq_name'], int(row['frame_idx']))] = \
                'seen' if row['gesture_in_training'] == '1' else 'unseen'
    if not groups:
        sys.exit(f'{path}: no held-out frames')
    return groups


def per_image_files(arg):
    if arg.endswith('.csv'):
        return [(os.path.basename(os.path.dirname(os.path.dirname(arg))) or arg, arg)]
    if os.path.isfile(os.path.join(arg, 'eval', 'per_image.csv')):
        return [(os.path.basename(os.path.normpath(arg)), os.path.join(arg, 'eval', 'per_image.csv'))]
    runs = os.path.join(arg, 'runs')
    if os.path.isdir(runs):
        found = [(name, os.path.join(runs, name, 'eval', 'per_image.csv')) for name in sorted(os.listdir(runs))]
        for name, path in found:
            if not os.path.isfile(path):
                print(f'warning: {path} missing: run {name} left out', file=sys.stderr)
        return [(name, path) for name, path in found if os.path.isfile(path)]
    sys.exit(f'{arg}: not a per_image.csv, a run folder with eval/per_image.csv, or a sweep folder')


def score(groups, path):
    values = {g: {m: [] for m in METRICS} for g in GROUPS}
    skipped = 0
    with open(path, newline='') as f:
        reader = csv.DictReader(f)
        if 'name' not in (reader.fieldnames or []):
            sys.exit(f'{path}: no column name (not a handscs-eval per_image.csv?)')
        for row in reader:
            match = NAME.match(row['name'])
            if not match:
                sys.exit(f'{path}: image name {row["name"]!r} is not <capture>/<sequence>/cam<id>/image<frame>.jpg')
            group = groups.get((match.group(1), int(match.group(2))))
            if group is None:
                sys.exit(f'{path}: {row["name"]} is not a held-out frame of frames.csv (another capture?)')
            for m in METRICS:
                try:
                    value = float(row[m])
                except (KeyError, ValueError):
                    value = math.nan
                if row.get('status', 'ok') != 'ok' or not math.isfinite(value):
                    skipped += 1
                    continue
                values[group][m].append(value)
    return {g: {m: (sum(v) / len(v) if v else math.nan, len(v)) for m, v in ms.items()}
            for g, ms in values.items()}, skipped


def main():
    args = sys.argv[1:]
    out_csv = None
    if '--csv' in args:
        i = args.index('--csv')
        if i + 1 >= len(args):
            sys.exit('--csv needs a file name')
        out_csv = args[i + 1]
        del args[i:i + 2]
    if len(args) < 2:
        sys.exit(__doc__)
    groups = read_frames(args[0])
    runs = [run for arg in args[1:] for run in per_image_files(arg)]
    if not runs:
        sys.exit('no per_image.csv found')
    header = ['run'] + [f'{g}_{m}' for g in GROUPS for m in ('images',) + METRICS] + ['values_left_out']
    rows = []
    for name, path in runs:
        scores, skipped = score(groups, path)
        row = [name]
        for g in GROUPS:
            row.append(scores[g]['psnr'][1])
            row += [scores[g][m][0] for m in METRICS]
        rows.append(row + [skipped])
    print('| run | seen: images | PSNR | SSIM | LPIPS | unseen: images | PSNR | SSIM | LPIPS | values left out |')
    print('|---|---|---|---|---|---|---|---|---|---|')
    for row in rows:
        cells = [row[0]] + [str(row[1]), f'{row[2]:.3f}', f'{row[3]:.4f}', f'{row[4]:.4f}',
                            str(row[5]), f'{row[6]:.3f}', f'{row[7]:.4f}', f'{row[8]:.4f}', str(row[9])]
        print('| ' + ' | '.join(cells) + ' |')
    if out_csv:
        with open(out_csv, 'w', newline='') as f:
            writer = csv.writer(f, lineterminator='\n')
            writer.writerow(header)
            writer.writerows(rows)


if __name__ == '__main__':
    main()
