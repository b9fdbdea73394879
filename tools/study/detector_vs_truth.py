#!/usr/bin/env python3
"""A detector's landmarks and handscs-fit's hands against a synthetic capture's true joints.

  detector_vs_truth.py frame --capture CAP --frame F --multiview MV [--fit FIT] [--json OUT]
        [--max-landmark-px PX] [--max-joint-mm MM] [--min-views N]
  detector_vs_truth.py table FRAME_JSON...
  detector_vs_truth.py pair DIR_A DIR_B
  detector_vs_truth.py exact --capture CAP --frame F --multiview MV

`frame` reads CAP/capture.json (the project's layout: cameras and the frame's true joints), the
views MV/views.json names (scripts/capture_to_multiview.py), the landmarks MV/pose/NN.json and,
with --fit, handscs-fit's capture.json and reprojection.json. The true joints are projected
through capture.json's own cameras, not through the converted archive. The bounds make it a
check: it exits 1 naming what broke them. --max-landmark-px bounds the median over the detections
of each one's median landmark error; --max-joint-mm the fitted joints' mean error; --min-views the
views with a detection. `table` prints the measurement's Markdown tables; `pair` compares two runs'
fitted joints frame by frame (FRAME.json in each folder). With a sequence's fit (several frames),
`frame` reads the fitted frame numbered F.
`exact` writes MV/pose/NN.json from the true joints projected, as a perfect detector would.
Standard library only.
"""
import argparse
import json
import math
import os
import statistics
import sys

# MANO21 joint j = MediaPipe landmark MEDIAPIPE[j] (hand/keypoint_order.h, kMano21FromMediaPipe).
MEDIAPIPE = [0, 5, 6, 7, 9, 10, 11, 17, 18, 19, 13, 14, 15, 1, 2, 3, 4, 8, 12, 16, 20]
# MANO21 indices of each finger's three joints and tip (hand/joint_order.h).
FINGERS = {"thumb": [13, 14, 15, 16], "index": [1, 2, 3, 17], "middle": [4, 5, 6, 18],
           "ring": [10, 11, 12, 19], "pinky": [7, 8, 9, 20]}


def project(camera, point):
    """Pixel (u, v) of a world point, the project's pixel centres (docs/CAPTURE_FORMAT.md)."""
    R, t, K = camera["R"], camera["t"], camera["K"]
    x = [sum(R[i][k] * point[k] for k in range(3)) + t[i] for i in range(3)]
    return (K[0][0] * x[0] / x[2] + K[0][2], K[1][1] * x[1] / x[2] + K[1][2])


def landmark_pixels(values, width, height):
    """A file's 63 numbers (MediaPipe order, [-1, 1]) as 21 pixels in MANO21 order."""
    return [((values[3 * m] + 1) / 2 * width, (values[3 * m + 1] + 1) / 2 * height) for m in MEDIAPIPE]


def write_exact_landmarks(a):
    """MV/pose/NN.json holding the true joints projected (z 0): a perfect detector's files."""
    capture, truth, views = read_truth(a)
    os.makedirs(os.path.join(a.multiview, "pose"), exist_ok=True)
    for view, name in views.items():
        camera = capture["cameras"][name]
        out = {"Left": [], "Right": []}
        for side, joints in truth.items():
            values = [0.0] * 63
            for j, m in enumerate(MEDIAPIPE):
                u, v = project(camera, joints[j])
                values[3 * m:3 * m + 2] = [u / camera["width"] * 2 - 1, v / camera["height"] * 2 - 1]
            # Labelled as MediaPipe would label the hand in a plain (not mirrored) image.
            out["Left" if side == "right" else "Right"] = values
        with open(os.path.join(a.multiview, "pose", view + ".json"), "w") as f:
            json.dump(out, f)


def read_truth(a):
    """capture.json, the frame's true joints per side, and MV's views (NN -> camera name)."""
    with open(os.path.join(a.capture, "capture.json")) as f:
        capture = json.load(f)
    frame = next(f for f in capture["frames"] if f["frame"] == a.frame)
    truth = {side: frame[side]["joints"] for side in ("right", "left") if frame.get(side)}
    with open(os.path.join(a.multiview, "views.json")) as f:
        views = json.load(f)
    return capture, truth, views


def summary(values):
    return {"mean": statistics.fmean(values), "median": statistics.median(values), "max": max(values)}


def frame_report(a):
    capture, truth, views = read_truth(a)
    report = {"frame": a.frame, "views": {}, "hands": {}}
    for view, name in sorted(views.items()):
        camera = capture["cameras"][name]
        projected = {side: [project(camera, p) for p in joints] for side, joints in truth.items()}
        path = os.path.join(a.multiview, "pose", view + ".json")
        with open(path) as f:
            landmarks = json.load(f)
        found = []
        for label, values in landmarks.items():
            if not values:
                continue
            pixels = landmark_pixels(values, camera["width"], camera["height"])
            # The true hand this detection lies on: the one its landmarks are closest to.
            errors = {side: [math.dist(p, q) for p, q in zip(pixels, projected[side])] for side in projected}
            side = min(errors, key=lambda s: statistics.median(errors[s]))
            found.append({"label": label, "hand": side, "median_px": statistics.median(errors[side]),
                          "max_px": max(errors[side])})
        report["views"][view] = {"camera": name, "detections": found}
    if a.fit:
        # A fit of one instant holds frame 0; a sequence's fit holds each fitted frame by its number.
        with open(os.path.join(a.fit, "capture.json")) as f:
            frames = json.load(f)["frames"]
        if [f["frame"] for f in frames] == [0]:
            fitted = frames[0]  # a fit of one instant
        else:
            fitted = next((f for f in frames if f["frame"] == a.frame), {"frame": a.frame})  # unfitted: no hands
        stem = f"{fitted['frame']:06d}"
        with open(os.path.join(a.fit, "reprojection.json")) as f:
            reprojection = json.load(f)
        with open(os.path.join(a.fit, "report.json")) as f:
            residual = {h["hand"]: h["mean_mm"] for h in json.load(f)["frames"] if h["frame"] == stem}
        for side in ("right", "left"):
            if not fitted.get(side):
                continue
            joints = fitted[side]["joints"]
            # Compared with the true hand it lies on, and said whether the fit named it rightly.
            errors = {t: [1000 * math.dist(p, q) for p, q in zip(joints, truth[t])] for t in truth}
            hand = min(errors, key=lambda t: statistics.fmean(errors[t]))
            e = errors[hand]
            instant = reprojection[side]["frames"][stem]
            dropped = instant["dropped_views_per_joint"]
            report["hands"][side] = {
                "true_hand": hand, "joint_mm": summary(e), "residual_mm": residual[side],
                "finger_mm": {finger: statistics.fmean(e[j] for j in js) for finger, js in FINGERS.items()},
                "per_joint_mm": e,
                "views_used": [v["view"] for v in instant["views"]],
                "dropped_views_per_joint": dropped,
                "joints_with_dropped_views": len(dropped),
                "fitted_median_px": instant["fitted_median_px"],
                "triangulated_median_px": instant["triangulated_median_px"]}
    return report


def check(report, a):
    """The bounds of --max-landmark-px, --max-joint-mm and --min-views; the breaches, named."""
    breaches = []
    px = [d["median_px"] for v in report["views"].values() for d in v["detections"]]
    if a.max_landmark_px is not None and px and statistics.median(px) > a.max_landmark_px:
        breaches.append(f"landmarks {statistics.median(px):.1f} px from the true joints (the median over "
                        f"{len(px)} detections of each one's median), over {a.max_landmark_px}")
    detected = sum(1 for v in report["views"].values() if v["detections"])
    if a.min_views is not None and detected < a.min_views:
        breaches.append(f"a hand found in {detected} views, fewer than {a.min_views}")
    if a.max_joint_mm is not None:
        if not report["hands"]:
            breaches.append("handscs-fit fitted no hand")
        for side, h in report["hands"].items():
            if h["true_hand"] != side:
                breaches.append(f"the fit's {side} hand lies on the true {h['true_hand']} hand")
            if h["joint_mm"]["mean"] > a.max_joint_mm:
                breaches.append(f"{side} hand: fitted joints {h['joint_mm']['mean']:.1f} mm (mean) from the "
                                f"true joints, over {a.max_joint_mm}")
    return breaches


def table(paths):
    reports = []
    for path in paths:
        with open(path) as f:
            reports.append(json.load(f))
    print("| frame | views with a hand | labels (Left / Right) | landmarks: median px | views used "
          "| joints with a view dropped | residual mm | fitted joints: mean / median / max mm | reprojection px "
          "| another hand fitted |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    all_errors, fingers, landmark_px = [], {f: [] for f in FINGERS}, []
    for r in reports:
        views = r["views"]
        detected = sum(1 for v in views.values() if v["detections"])
        labels = [d["label"] for v in views.values() for d in v["detections"]]
        px = [d["median_px"] for v in views.values() for d in v["detections"]]
        landmark_px += px
        cells = [str(r["frame"]), f"{detected} / {len(views)}",
                 f"{labels.count('Left')} / {labels.count('Right')}",
                 f"{statistics.median(px):.1f}" if px else "-"]
        hand = r["hands"].get("right") or r["hands"].get("left")
        if hand:
            side = "right" if r["hands"].get("right") else "left"
            name = "" if hand["true_hand"] == side else f" (fitted as {side})"
            j = hand["joint_mm"]
            all_errors += hand["per_joint_mm"]
            for finger, value in hand["finger_mm"].items():
                fingers[finger].append(value)
            cells += [str(len(hand["views_used"])), str(hand["joints_with_dropped_views"]), f"{hand['residual_mm']:.1f}",
                      f"{j['mean']:.1f} / {j['median']:.1f} / {j['max']:.1f}{name}",
                      f"{hand['fitted_median_px']:.1f}"]
            # A second fitted hand: a phantom when the capture has one hand.
            other = r["hands"].get("left") if side == "right" else None
            cells.append(f"a left hand on the true {other['true_hand']} one, {len(other['views_used'])} views, "
                         f"{other['joint_mm']['mean']:.1f} mm" if other else "-")
        else:
            cells += ["-", "-", "-", "no hand fitted", "-", "-"]
        print("| " + " | ".join(cells) + " |")
    if all_errors:
        s = summary(all_errors)
        print(f"\nAll fitted joints: mean {s['mean']:.1f}, median {s['median']:.1f}, max {s['max']:.1f} mm "
              f"({len(all_errors)} joints). Landmarks: median {statistics.median(landmark_px):.1f} px over "
              f"{len(landmark_px)} detections.")
        print("\n| finger (three joints and tip) | " + " | ".join(FINGERS) + " |")
        print("|---" * (len(FINGERS) + 1) + "|")
        print("| mean over frames, mm | " + " | ".join(f"{statistics.fmean(v):.1f}" for v in fingers.values()) + " |")
        print("| median over frames, mm | " + " | ".join(f"{statistics.median(v):.1f}" for v in fingers.values()) + " |")
    # MediaPipe labels a plain (not mirrored) image's right hand "Left": the label against the
    # landmarks' quality.
    for label in ("Left", "Right"):
        px = [d["median_px"] for r in reports for v in r["views"].values() for d in v["detections"] if d["label"] == label]
        if px:
            print(f"\nDetections labelled {label}: {len(px)}, landmarks median {statistics.median(px):.1f} px, "
                  f"{sum(1 for x in px if x > 30)} over 30 px.")


def pair(dir_a, dir_b):
    """Per frame, the fitted joints' mean error of run A and run B (FRAME.json in each folder), the
    gain A - B, and its mean and std over the frames both fitted. One hand per frame: the right one
    when fitted, else the left (the measurement's capture holds one hand)."""
    def mean_mm(path):
        with open(path) as f:
            hands = json.load(f)["hands"]
        hand = hands.get("right") or hands.get("left")
        return hand["joint_mm"]["mean"] if hand else None
    names = sorted((n for n in os.listdir(dir_a)
                    if n[:-5].isdigit() and n.endswith(".json") and os.path.exists(os.path.join(dir_b, n))),
                   key=lambda n: int(n[:-5]))
    print(f"| frame | {dir_a}: joints mean mm | {dir_b}: joints mean mm | gain A - B, mm |")
    print("|---|---|---|---|")
    gains = []
    for n in names:
        a, b = mean_mm(os.path.join(dir_a, n)), mean_mm(os.path.join(dir_b, n))
        gain = a - b if a is not None and b is not None else None
        if gain is not None:
            gains.append(gain)
        cell = lambda x: "no hand fitted" if x is None else f"{x:.2f}"
        print(f"| {n[:-5]} | {cell(a)} | {cell(b)} | {'-' if gain is None else f'{gain:+.2f}'} |")
    if len(gains) > 1:
        print(f"\nGain A - B over {len(gains)} frames: mean {statistics.fmean(gains):+.2f} mm, std "
              f"{statistics.stdev(gains):.2f} mm; positive on {sum(1 for g in gains if g > 0)}, negative on "
              f"{sum(1 for g in gains if g < 0)}.")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    f = sub.add_parser("frame")
    f.add_argument("--capture", required=True)
    f.add_argument("--frame", required=True, type=int)
    f.add_argument("--multiview", required=True)
    f.add_argument("--fit")
    f.add_argument("--json")
    f.add_argument("--max-landmark-px", type=float)
    f.add_argument("--max-joint-mm", type=float)
    f.add_argument("--min-views", type=int)
    e = sub.add_parser("exact")
    for key in ("--capture", "--multiview"):
        e.add_argument(key, required=True)
    e.add_argument("--frame", required=True, type=int)
    t = sub.add_parser("table")
    t.add_argument("reports", nargs="+")
    p = sub.add_parser("pair")
    p.add_argument("a")
    p.add_argument("b")
    a = parser.parse_args()
    if a.command == "table":
        table(a.reports)
        return
    if a.command == "pair":
        pair(a.a, a.b)
        return
    if a.command == "exact":
        write_exact_landmarks(a)
        return
    report = frame_report(a)
    text = json.dumps(report, indent=1)
    if a.json:
        with open(a.json, "w") as out:
            out.write(text + "\n")
    breaches = check(report, a)
    for b in breaches:
        print("detector_vs_truth: " + b, file=sys.stderr)
    sys.exit(1 if breaches else 0)


if __name__ == "__main__":
    main()
