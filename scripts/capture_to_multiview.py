#!/usr/bin/env python3
"""One frame of a capture in the project's layout (capture.json) as the multi-view layout that
`handscs-fit --multiview` reads (NeuS/IDR/FMHR's, fit/multiview_capture.h):

  OUT/cameras.npz      world_mat_i = K [R | t] per camera, K in OpenCV's pixel centres
  OUT/img/NN.<ext>     links to the frame's images, cameras numbered in capture.json's order
  OUT/views.json       which camera each NN is
  OUT/true_joints.json the frame's joints from capture.json, when it has them (metres, MANO21)

Then OUT/pose/NN.json takes a detector's landmarks (scripts/detect_landmarks.sh).
Standard library only (no NumPy): the archive's arrays are written as .npy by hand.

  capture_to_multiview.py CAPTURE_DIR FRAME OUT_DIR
"""
import argparse
import json
import os
import struct
import sys
import zipfile


def npy_bytes(rows):
    """A float64 C-order .npy file (format 1.0) holding the matrix `rows`."""
    shape = (len(rows), len(rows[0]))
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (%d, %d), }" % shape
    # The magic, version and header length take 10 bytes; the header ends in a newline, padded
    # with spaces so the data start on a multiple of 64 bytes.
    padding = 64 - (10 + len(header) + 1) % 64
    header = header + " " * (padding % 64) + "\n"
    out = b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode("latin1")
    return out + b"".join(struct.pack("<d", float(x)) for row in rows for x in row)


def world_mat(camera):
    """K [R | t] as 4x4, K back in OpenCV's pixel centres (the reader adds the half pixel again)."""
    K = [list(map(float, row)) for row in camera["K"]]
    K[0][2] -= 0.5
    K[1][2] -= 0.5
    Rt = [list(map(float, camera["R"][i])) + [float(camera["t"][i])] for i in range(3)]
    P = [[sum(K[i][k] * Rt[k][j] for k in range(3)) for j in range(4)] for i in range(3)]
    return P + [[0.0, 0.0, 0.0, 1.0]]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("capture", help="a folder holding capture.json and images/<camera>/")
    parser.add_argument("frame", type=int, help="the frame number (frames[].frame)")
    parser.add_argument("out", help="the folder to write (must not exist or be empty)")
    a = parser.parse_args()

    path = os.path.join(a.capture, "capture.json")
    with open(path) as f:
        capture = json.load(f)
    if capture.get("format") != "handscs-capture":
        sys.exit(f"{path}: not a capture in the project's layout (format handscs-capture)")
    for name, camera in capture["cameras"].items():
        if any(abs(float(k)) > 0 for k in camera.get("dist", [])):
            sys.exit(f"{path}: cameras.{name} has lens distortion; the multi-view layout has none")
    frames = [f for f in capture["frames"] if f["frame"] == a.frame]
    if not frames:
        sys.exit(f"{path}: no frame {a.frame}")
    if os.path.exists(a.out) and os.listdir(a.out):
        sys.exit(f"{a.out}: not empty")

    os.makedirs(os.path.join(a.out, "img"), exist_ok=True)
    arrays, views = {}, {}
    stem = "%06d" % a.frame
    for i, (name, camera) in enumerate(capture["cameras"].items()):
        found = [e for e in (".jpg", ".png") if os.path.exists(os.path.join(a.capture, "images", name, stem + e))]
        if not found:
            sys.exit(f"{a.capture}/images/{name}/{stem}.jpg: missing")
        image = os.path.abspath(os.path.join(a.capture, "images", name, stem + found[0]))
        os.symlink(image, os.path.join(a.out, "img", "%02d%s" % (i, found[0])))
        arrays["world_mat_%d" % i] = world_mat(camera)
        views["%02d" % i] = name
    with zipfile.ZipFile(os.path.join(a.out, "cameras.npz"), "w") as z:
        for key, rows in arrays.items():
            z.writestr(key + ".npy", npy_bytes(rows))
    with open(os.path.join(a.out, "views.json"), "w") as f:
        json.dump(views, f, indent=1)
    truth = {side: frames[0][side]["joints"] for side in ("right", "left")
             if frames[0].get(side) and "joints" in frames[0][side]}
    if truth:
        with open(os.path.join(a.out, "true_joints.json"), "w") as f:
            json.dump(truth, f)


if __name__ == "__main__":
    main()
