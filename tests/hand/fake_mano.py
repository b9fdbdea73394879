#!/usr/bin/env python3
"""Test helper: writes small fake MANO pickles shaped like the real ones, and reference LBS outputs.

The pickles mimic MANO_RIGHT.pkl / MANO_LEFT.pkl as written by Python 2: protocol 2, every string
(dictionary keys, numpy's raw array bytes) a Python-2 'str' (BINSTRING opcodes, read back with
encoding='latin1'), shapedirs as the released files hold it: a chumpy.reordering.Select whose state
holds 'a' (a chumpy.ch.Ch with 20 shape components in 'x'), 'idxs' (flat indices of the first 10) and
'preferred_shape' (V, 3, 10); J_regressor a scipy.sparse.csc.csc_matrix (state data, indices, indptr,
_shape, maxprint); the released extra keys (J, hands_components, hands_coeffs, bs_style, bs_type).
Neither chumpy nor scipy is needed: the classes are stand-ins registered under those module names.
Also written: the right hand as a plain dictionary of numpy arrays pickled by Python 3 with protocol
2 (plain_right.pkl), and files the converter must refuse (a missing key, an unsupported chumpy
expression, a body model with 24 joints, a dictionary that is no model, a right hand turned 90
degrees about x (its back facing +z: no hand in MANO's frame), a _codecs.encode call with
an encoding other than latin1, and J_regressor's sparse matrix damaged each way in SPARSE_DAMAGE).

The reference is MANO's LBS written here in numpy (independent of the C++ code), for the converted
rig (left hand: with the shapedirs fix), for a few poses/shapes/translations, with and without
flat_hand_mean.

Usage: fake_mano.py OUT_DIR   -> OUT_DIR/MANO_RIGHT.pkl, MANO_LEFT.pkl, plain_right.pkl,
                                 reference.json and the refused broken_right, unsupported_right,
                                 body_right, other_right, turned_right, codecs_right,
                                 sparse_*_right.pkl
"""

import codecs
import io
import json
import os
import pickle
import struct
import sys
import types

import numpy as np

V, F = 40, 30
TIPS = [3, 11, 19, 27, 35]
PARENTS = [-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14]


# --- stand-in classes under the names the real pickles use ------------------------------------
class Ch(object):
    def __init__(self, x):
        self.x = x
        self._dirty_vars = set()
        self._itr = None


class Select(object):
    """chumpy.reordering.Select: value a.r.ravel()[idxs].reshape(preferred_shape)."""

    def __init__(self, a, idxs, preferred_shape):
        self.a = a
        self.idxs = idxs
        self.preferred_shape = preferred_shape
        self._dirty_vars = set()
        self._itr = None


class add(object):
    """chumpy.ch_ops.add: an expression the converter does not evaluate (it must say so)."""

    def __init__(self, a, b):
        self.a = a
        self.b = b


class csc_matrix(object):
    def __init__(self, dense):
        rows, cols = dense.shape
        data, indices, indptr = [], [], [0]
        for j in range(cols):
            for i in range(rows):
                if dense[i, j] != 0:
                    data.append(dense[i, j])
                    indices.append(i)
            indptr.append(len(data))
        self.data = np.array(data, dtype=np.float64)
        self.indices = np.array(indices, dtype=np.int32)
        self.indptr = np.array(indptr, dtype=np.int32)
        self._shape = (rows, cols)
        self.maxprint = 50


def _register(module_name, cls):
    parts = module_name.split(".")
    for i in range(1, len(parts) + 1):
        name = ".".join(parts[:i])
        if name not in sys.modules:
            sys.modules[name] = types.ModuleType(name)
    setattr(sys.modules[module_name], cls.__name__, cls)
    cls.__module__ = module_name


_register("chumpy.ch", Ch)
_register("chumpy.reordering", Select)
_register("chumpy.ch_ops", add)
_register("scipy.sparse.csc", csc_matrix)


class Py2Pickler(pickle._Pickler):
    """Protocol-2 pickler writing text and bytes as Python-2 'str' (SHORT_BINSTRING, BINSTRING)."""

    dispatch = pickle._Pickler.dispatch.copy()

    def _write_py2_str(self, obj, data):
        if len(data) < 256:
            self.write(pickle.SHORT_BINSTRING + bytes([len(data)]) + data)
        else:
            self.write(pickle.BINSTRING + struct.pack("<i", len(data)) + data)
        self.memoize(obj)

    def save_bytes(self, obj):
        self._write_py2_str(obj, obj)

    def save_text(self, obj):
        self._write_py2_str(obj, obj.encode("latin1"))

    dispatch[bytes] = save_bytes
    dispatch[str] = save_text


def py2_pickle(obj):
    stream = io.BytesIO()
    Py2Pickler(stream, protocol=2).dump(obj)
    return stream.getvalue()


class CodecsCall(object):
    """Pickles as _codecs.encode(text, encoding): the call protocol 2 makes for bytes, here with an
    encoding the converter must refuse."""

    def __init__(self, text, encoding):
        self.text = text
        self.encoding = encoding

    def __reduce__(self):
        return codecs.encode, (self.text, self.encoding)


def plain_model(model):
    """The model as a plain dictionary of numpy arrays (J_regressor dense, shapedirs evaluated), to
    be pickled by Python 3's own pickle with protocol 2: its raw array bytes become
    _codecs.encode(text, 'latin1') calls."""
    plain = dict(model)
    sparse = model["J_regressor"]
    regressor = np.zeros(sparse._shape)
    for j in range(sparse._shape[1]):
        for p in range(sparse.indptr[j], sparse.indptr[j + 1]):
            regressor[sparse.indices[p], j] = sparse.data[p]
    plain["J_regressor"] = regressor
    plain["shapedirs"] = shapedirs_value(model)
    return plain


def released_shapedirs(components):
    """shapedirs as MANO_RIGHT.pkl stores it: the first 10 of 20 shape components, selected."""
    idxs = np.arange(components.size).reshape(components.shape)[:, :, :10].ravel()
    return Select(Ch(components), idxs, (components.shape[0], 3, 10))


def shapedirs_value(model):
    """The shapedirs array the Select stands for, computed by slicing (not through idxs)."""
    return model["shapedirs"].a.x[:, :, :10].copy()


# --- the fake model ------------------------------------------------------------------------------
# A right hand's rest joints laid out in MANO's frame (docs/RIG_FORMAT.md: fingers along -x from the
# wrist, thumb and index on the +z side, back of the hand +y), in metres; round numbers, not MANO's.
RIGHT_JOINTS = np.array([
    [0.090, 0.0, 0.0],                                                # wrist
    [0.005, 0.0, 0.025], [-0.030, 0.0, 0.028], [-0.055, 0.0, 0.030],  # index
    [0.000, 0.0, 0.005], [-0.040, 0.0, 0.005], [-0.065, 0.0, 0.005],  # middle
    [0.015, 0.0, -0.035], [-0.010, 0.0, -0.040], [-0.030, 0.0, -0.045],  # pinky
    [0.005, 0.0, -0.015], [-0.030, 0.0, -0.018], [-0.055, 0.0, -0.020],  # ring
    [0.065, -0.010, 0.025], [0.045, -0.015, 0.045], [0.025, -0.020, 0.060],  # thumb
])


def make_model(rng, left):
    """Vertex v sits near joint v % 16 (5 mm of noise) and the regressor averages each joint's own
    vertices, so the rest joints form a hand (the converter checks its handedness); the left hand
    is the right one mirrored through x = 0."""
    owner = np.arange(V) % 16
    v_template = RIGHT_JOINTS[owner] + rng.normal(scale=0.005, size=(V, 3))
    if left:
        v_template[:, 0] *= -1
    faces = np.array([[i, (i + 1) % V, (i + 7) % V] for i in range(F)], dtype=np.uint32)
    weights = rng.random((V, 16)) * (rng.random((V, 16)) > 0.5)
    weights[:, 0] += 1e-3
    weights /= weights.sum(axis=1, keepdims=True)
    regressor = rng.random((16, V)) * (owner[None, :] == np.arange(16)[:, None])
    regressor /= regressor.sum(axis=1, keepdims=True)
    kintree = np.array([[4294967295] + PARENTS[1:], list(range(16))], dtype=np.int64)
    return {
        "v_template": v_template,
        "f": faces,
        "weights": weights,
        "J_regressor": csc_matrix(regressor),
        "kintree_table": kintree,
        "posedirs": rng.normal(scale=1e-3, size=(V, 3, 135)),
        "shapedirs": released_shapedirs(rng.normal(scale=1e-2, size=(V, 3, 20))),
        "hands_mean": rng.normal(scale=0.2, size=45),
        "hands_components": rng.normal(size=(45, 45)),
        "hands_coeffs": rng.normal(size=(10, 45)),
        "J": regressor @ v_template,
        "bs_style": "lbs",
        "bs_type": "lrotmin",
    }


def _set_regressor(**state):
    def edit(model):
        for name, value in state.items():
            setattr(model["J_regressor"], name, value)
    return edit


def _huge_shapedirs_source(model):
    """shapedirs a Select of a sparse matrix of 10^8 values (no expected shape reaches it)."""
    sparse = csc_matrix(np.zeros((1, 1)))
    sparse._shape = (100000, 1000)
    sparse.indptr = np.zeros(1001, dtype=np.int32)
    model["shapedirs"].a = sparse


# J_regressor damaged each way the converter must name before it allocates anything.
SPARSE_DAMAGE = {
    "huge": _set_regressor(_shape=(1000000, 1000000)),
    "big": _set_regressor(_shape=(40000, 40000)),
    "negative": _set_regressor(_shape=(-16, V)),
    "fractional": _set_regressor(_shape=(16.5, V)),
    "index": lambda model: model["J_regressor"].indices.__setitem__(0, 10**9),
    "pointers": lambda model: model["J_regressor"].indptr.__setitem__(1, 10**6),
    "nested": _huge_shapedirs_source,
}


# --- reference LBS (MANO, numpy) ---------------------------------------------------------------
def rodrigues(a):
    theta = np.linalg.norm(a)
    if theta < 1e-12:
        return np.eye(3)
    k = a / theta
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K


def reference_lbs(model, shapedirs, pose, beta, trans, flat_hand_mean):
    pose = np.array(pose, dtype=np.float64)
    if not flat_hand_mean:
        pose[3:] += model["hands_mean"]
    regressor = np.zeros((16, V))
    sparse = model["J_regressor"]
    for j in range(V):
        for p in range(sparse.indptr[j], sparse.indptr[j + 1]):
            regressor[sparse.indices[p], j] = sparse.data[p]
    v_shaped = model["v_template"] + shapedirs @ beta
    J = regressor @ v_shaped
    R = [rodrigues(pose[3 * k:3 * k + 3]) for k in range(16)]
    feature = np.concatenate([(R[k] - np.eye(3)).ravel() for k in range(1, 16)])
    v_posed = v_shaped + model["posedirs"] @ feature
    G = []
    for k in range(16):
        local = np.eye(4)
        local[:3, :3] = R[k]
        local[:3, 3] = J[k] - (J[PARENTS[k]] if k else 0)
        G.append(local if k == 0 else G[PARENTS[k]] @ local)
    A = []
    for k in range(16):
        a = G[k].copy()
        a[:3, 3] -= G[k][:3, :3] @ J[k]
        A.append(a)
    T = np.einsum("vk,kij->vij", model["weights"], np.array(A))
    homogeneous = np.concatenate([v_posed, np.ones((V, 1))], axis=1)
    vertices = np.einsum("vij,vj->vi", T, homogeneous)[:, :3] + trans
    rig_joints = [G[k][:3, 3] for k in range(16)]
    joints = np.array(rig_joints + [vertices[t] - trans for t in TIPS]) + trans
    return vertices, joints


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(1234)
    reference = {"tips": TIPS, "cases": []}
    poses = [np.zeros(48), rng.normal(scale=0.6, size=48), rng.normal(scale=0.3, size=48)]
    betas = [np.zeros(10), rng.normal(size=10), rng.normal(size=10)]
    translations = [np.zeros(3), rng.normal(scale=0.1, size=3), rng.normal(scale=0.1, size=3)]
    for hand in ("right", "left"):
        model = make_model(rng, hand == "left")
        with open(os.path.join(out, f"MANO_{hand.upper()}.pkl"), "wb") as stream:
            stream.write(py2_pickle(model))
        if hand == "right":
            with open(os.path.join(out, "plain_right.pkl"), "wb") as stream:
                pickle.dump(plain_model(model), stream, protocol=2)
        shapedirs = shapedirs_value(model)
        if hand == "left":
            shapedirs[:, 0, :] *= -1  # the converter's left-hand fix
        for pose, beta, trans in zip(poses, betas, translations):
            for flat in (True, False):
                vertices, joints = reference_lbs(model, shapedirs, pose, beta, trans, flat)
                reference["cases"].append({
                    "hand": hand, "flat_hand_mean": flat, "pose": pose.tolist(),
                    "shape": beta.tolist(), "trans": trans.tolist(),
                    "vertices": vertices.tolist(), "joints": joints.tolist()})
    broken = make_model(rng, False)
    del broken["J_regressor"]
    with open(os.path.join(out, "broken_right.pkl"), "wb") as stream:
        stream.write(py2_pickle(broken))
    unsupported = make_model(rng, False)
    unsupported["shapedirs"] = add(unsupported["shapedirs"], unsupported["shapedirs"])
    with open(os.path.join(out, "unsupported_right.pkl"), "wb") as stream:
        stream.write(py2_pickle(unsupported))
    body = make_model(rng, False)
    body["kintree_table"] = np.array([[4294967295] + list(range(23)), list(range(24))])
    with open(os.path.join(out, "body_right.pkl"), "wb") as stream:
        stream.write(py2_pickle(body))
    with open(os.path.join(out, "other_right.pkl"), "wb") as stream:
        stream.write(py2_pickle({"weights_of_a_network": np.zeros(3), "epoch": 7}))
    for name, edit in SPARSE_DAMAGE.items():
        damaged = make_model(rng, False)
        edit(damaged)
        with open(os.path.join(out, f"sparse_{name}_right.pkl"), "wb") as stream:
            stream.write(py2_pickle(damaged))
    turned = make_model(rng, False)
    turned["v_template"] = turned["v_template"] @ np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]])
    with open(os.path.join(out, "turned_right.pkl"), "wb") as stream:
        stream.write(py2_pickle(turned))
    codecs_call = make_model(rng, False)
    codecs_call["bs_style"] = CodecsCall("lbs", "utf-16")
    with open(os.path.join(out, "codecs_right.pkl"), "wb") as stream:
        pickle.dump(codecs_call, stream, protocol=2)
    with open(os.path.join(out, "reference.json"), "w") as stream:
        json.dump(reference, stream)


if __name__ == "__main__":
    main()
