#!/usr/bin/python3
"""Each camera's colour response of a synthetic capture, measured against the same capture made
without it (handscs-synth --set effects.camera_response=false, same preset and seed).

Per camera and channel: the sum of the capture's pixel values over the sum of the plain capture's,
over the pixels where the plain image is brighter than 20 levels (the hand; vignetting and noise
included), then divided by the mean over the colour cameras (monochrome ones, R = G = B, are
listed but left out of the mean, as training drops them) -- what a per-camera gain learned with
its mean held at 1 should find. With --run RUN_DIR also the run's learned transforms
(camera_color.csv), as the response at the camera's mean plain hand colour (A c + b) / c.
Usage: /usr/bin/python3 tools/study/camera_response_ratio.py CAPTURE PLAIN_CAPTURE [--run RUN_DIR]
"""
import argparse
import csv
import os
import sys

import numpy as np
from PIL import Image


def camera_images(root):
    out = {}
    for folder, _, files in os.walk(os.path.join(root, "images")):
        name = os.path.basename(folder)
        if not name.startswith("cam"):
            continue
        for f in files:
            if f.endswith(".jpg"):
                out.setdefault(name[3:], []).append(os.path.relpath(os.path.join(folder, f), root))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("capture")
    parser.add_argument("plain")
    parser.add_argument("--run", help="a run folder with camera_color.csv")
    args = parser.parse_args()
    cameras = camera_images(args.capture)
    if not cameras:
        sys.exit(f"camera_response_ratio: no images under {args.capture}/images")
    ratio, colour, mono = {}, {}, {}
    for cam, paths in sorted(cameras.items()):
        num, den, count, grey = np.zeros(3), np.zeros(3), 0, True
        for rel in paths:
            real = np.asarray(Image.open(os.path.join(args.capture, rel)).convert("RGB"), np.float64)
            plain = np.asarray(Image.open(os.path.join(args.plain, rel)).convert("RGB"), np.float64)
            hand = plain.mean(2) > 20
            num += real[hand].sum(0)
            den += plain[hand].sum(0)
            count += int(hand.sum())
            grey = grey and np.abs(real[..., 0] - real[..., 2]).max() == 0
        ratio[cam], colour[cam], mono[cam] = num / den, den / (255.0 * count), grey
    colour_cams = [c for c in ratio if not mono[c]]
    mean = np.mean([ratio[c] for c in colour_cams], axis=0)
    learned = {}
    if args.run:
        with open(os.path.join(args.run, "camera_color.csv")) as f:
            for r in csv.DictReader(f):
                a = np.array([[float(r[f"{i}_{j}"]) for j in "rgb"] for i in "rgb"])
                b = np.array([float(r[f"{i}_bias"]) for i in "rgb"])
                learned[r["camera_id"]] = (a, b)
    print("| camera | measured R / G / B (relative) |" + (" learned at the hand colour R / G / B | difference |" if learned else ""))
    print("|---|---|" + ("---|---|" if learned else ""))
    errors = []
    for cam in sorted(ratio):
        rel = ratio[cam] / mean
        cells = [cam + (" (monochrome)" if mono[cam] else ""), " / ".join(f"{v:.3f}" for v in rel)]
        if cam in learned:
            # The transform's response to the camera's mean plain hand colour, channel by channel.
            c = colour[cam]
            a, b = learned[cam]
            got = (a @ c + b) / c
            cells += [" / ".join(f"{v:.3f}" for v in got), " / ".join(f"{v:+.3f}" for v in got - rel)]
            errors += list(np.abs(got - rel))
        elif learned:
            cells += ["(no transform)", ""]
        print("| " + " | ".join(cells) + " |")
    if errors:
        print(f"\nlargest difference {max(errors):.3f}, mean {np.mean(errors):.3f} over {len(errors)} channel values")


if __name__ == "__main__":
    main()
