#!/usr/bin/env python3
"""Convert a MANO hand model pickle (MANO_RIGHT.pkl / MANO_LEFT.pkl) into a HandSCS rig file.

MANO is licence-restricted (https://mano.is.tue.mpg.de): download it yourself, convert it with this
script, and never commit or redistribute the pickle or the rig file made from it.

Needs only python3 and numpy. The pickle is a Python-2 pickle holding chumpy and scipy objects; this
script reads it with encoding='latin1' and replaces those classes (and any other unknown class) by
inert stand-ins whose pickled state it reads directly: a chumpy Ch keeps its array in 'x'; the chumpy
expressions the released files use are evaluated from their state (Select: a.ravel()[idxs] reshaped
to preferred_shape, as MANO_RIGHT.pkl's shapedirs is; Reshape; Transpose); a scipy csc_matrix keeps
data/indices/indptr/_shape. No code from the pickle is ever run.

The rig file format is docs/RIG_FORMAT.md. For the left hand the known shapedirs bug of the released
MANO_LEFT.pkl is fixed (shapedirs[:, 0, :] *= -1; pass --no-left-shapedirs-fix for a fixed file).

Usage:
  convert_mano.py MANO_RIGHT.pkl mano_right.json
  convert_mano.py MANO_LEFT.pkl mano_left.json [--hand left] [--tips 745,317,445,556,673]

An existing output file is replaced only with --force; the input pickle never is.
"""

import argparse
import json
import operator
import os
import pickle
import stat
import sys

try:
    import numpy as np
except ImportError:  # pragma: no cover - depends on the machine
    sys.exit("convert_mano.py: needs numpy (Debian: apt install python3-numpy; "
             "run it with /usr/bin/python3)")

MANO_PARENTS = [-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14]
# Fingertip vertices (thumb, index, middle, ring, pinky), as InterHand2.6M's regressor uses them.
MANO_TIP_VERTICES = [745, 317, 445, 556, 673]
MANO_VERTICES = 778
# Rows of the skinning weights must sum to 1 within this (the rig loader's tolerance).
SUM_TOLERANCE = 1e-4


class ConversionError(Exception):
    """Bad input: reported with the pickle's path."""


class OutputError(Exception):
    """An output that must not be written: reported with the output's path."""


class _Inert:
    """Stand-in for a class of the pickle: keeps constructor arguments and state, runs nothing."""

    def __init__(self, *args, **kwargs):
        self.__dict__["_args"] = args

    def __setstate__(self, state):
        self.__dict__["_state"] = state

    def state(self):
        return self.__dict__.get("_state")


class ChumpyObject(_Inert):
    """A chumpy object; chumpy_class names the expression (Ch, Select, ...) its state describes."""
    chumpy_class = "chumpy.ch.Ch"


_CHUMPY_CLASSES = {}


def chumpy_stand_in(module, name):
    """One inert stand-in class per chumpy class name, so evaluation knows which expression it is."""
    full_name = f"{module}.{name}"
    if full_name not in _CHUMPY_CLASSES:
        _CHUMPY_CLASSES[full_name] = type(name, (ChumpyObject,), {"chumpy_class": full_name})
    return _CHUMPY_CLASSES[full_name]


# MANO's largest array, posedirs, holds 778 x 3 x 135 = 315,090 values; a sparse matrix standing for
# more than 10 million (80 MB dense) is no MANO array, and is refused before anything is allocated.
MAX_SPARSE_VALUES = 10_000_000


class SparseMatrix(_Inert):
    def toarray(self, key, expected_shape=None):
        """The dense matrix, after checking its shape (against expected_shape when the key has
        one) before allocating it, and every pointer and index against that shape."""
        state = self.state()
        layout = self.layout
        if not isinstance(state, dict):
            raise ConversionError(f"{key}: scipy sparse matrix without a state dictionary")
        shape = state.get("_shape", state.get("shape"))
        try:
            rows, cols = (operator.index(n) for n in shape)
        except (TypeError, ValueError):
            raise ConversionError(f"{key}: {layout} matrix without a _shape of two integers") \
                from None
        if rows < 0 or cols < 0:
            raise ConversionError(f"{key}: {layout} matrix of negative shape [{rows}, {cols}]")
        if expected_shape is not None and (rows, cols) != tuple(expected_shape):
            raise ConversionError(
                f"{key}: expected shape {list(expected_shape)}, got [{rows}, {cols}]")
        if rows * cols > MAX_SPARSE_VALUES:
            raise ConversionError(f"{key}: {layout} matrix of shape [{rows}, {cols}]: more values "
                                  f"than any MANO array (at most {MAX_SPARSE_VALUES})")
        arrays = {}
        for name, kinds in (("data", "fiu"), ("indices", "iu"), ("indptr", "iu")):
            if name not in state:
                raise ConversionError(f"{key}: {layout} matrix without its '{name}'")
            array = np.asarray(state[name])
            if array.ndim != 1 or array.dtype.kind not in kinds:
                raise ConversionError(f"{key}: {layout} matrix '{name}' is not a flat array of "
                                      f"{'numbers' if name == 'data' else 'integers'}")
            arrays[name] = array
        data = arrays["data"].astype(np.float64)
        indices = arrays["indices"].astype(np.int64)
        indptr = arrays["indptr"].astype(np.int64)
        outer, inner = (cols, rows) if layout == "csc" else (rows, cols)
        if len(indptr) != outer + 1:
            raise ConversionError(
                f"{key}: {layout} matrix with {len(indptr)} pointers for {outer} slices")
        if len(indices) != len(data):
            raise ConversionError(
                f"{key}: {layout} matrix with {len(data)} values but {len(indices)} indices")
        if indptr[0] != 0 or indptr[-1] != len(data) or np.any(np.diff(indptr) < 0):
            raise ConversionError(f"{key}: {layout} matrix indptr does not rise from 0 to its "
                                  f"{len(data)} values")
        bad = np.flatnonzero((indices < 0) | (indices >= inner))
        if bad.size:
            axis = "row" if layout == "csc" else "column"
            raise ConversionError(f"{key}: {layout} matrix {axis} index {indices[bad[0]]} out of "
                                  f"range [0, {inner})")
        slices = np.repeat(np.arange(outer), np.diff(indptr))
        dense = np.zeros((rows, cols), dtype=np.float64)
        if layout == "csc":
            np.add.at(dense, (indices, slices), data)
        else:
            np.add.at(dense, (slices, indices), data)
        return dense


class CscMatrix(SparseMatrix):
    layout = "csc"


class CsrMatrix(SparseMatrix):
    layout = "csr"


# Classes the pickle may construct for real: numpy arrays and the plain builtins pickle needs.
_ALLOWED = {
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy.core.numeric", "_frombuffer"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("copy_reg", "_reconstructor"),
    ("copyreg", "_reconstructor"),
    ("__builtin__", "object"),
    ("builtins", "object"),
    ("__builtin__", "set"),
    ("builtins", "set"),
    ("__builtin__", "frozenset"),
    ("builtins", "frozenset"),
    ("__builtin__", "list"),
    ("builtins", "list"),
    ("__builtin__", "dict"),
    ("builtins", "dict"),
    ("__builtin__", "tuple"),
    ("builtins", "tuple"),
    ("__builtin__", "slice"),
    ("builtins", "slice"),
    ("__builtin__", "complex"),
    ("builtins", "complex"),
}


def latin1_bytes(text, encoding=None):
    """_codecs.encode as protocol-2 pickles from Python 3 use it: numpy's raw array bytes arrive
    as _codecs.encode(str, 'latin1'). Only that call is answered (any other is refused)."""
    if not isinstance(text, str) or encoding != "latin1":
        raise ConversionError(f"the pickle calls _codecs.encode with a {type(text).__name__} and "
                              f"{encoding!r}: only latin1 text to bytes is supported")
    return text.encode("latin1")


class ManoUnpickler(pickle.Unpickler):
    def find_class(self, module, name):
        if (module, name) == ("_codecs", "encode"):
            return latin1_bytes
        if module.startswith("chumpy"):
            return chumpy_stand_in(module, name)
        if module.startswith("scipy.sparse") and name == "csc_matrix":
            return CscMatrix
        if module.startswith("scipy.sparse") and name == "csr_matrix":
            return CsrMatrix
        if (module, name) in _ALLOWED:
            return super().find_class(module, name)
        # An allow list: anything else could run code when called, however harmless its name.
        raise ConversionError(f"the pickle asks for {module}.{name}, which a MANO file does not "
                              "need: refusing to load it")


# chumpy expressions nest (Select of a Ch); deeper than this is a cycle or not a MANO file.
MAX_CHUMPY_DEPTH = 16


def chumpy_value(value, key, depth):
    """The array a chumpy object evaluates to, computed from its pickled state alone."""
    name = value.chumpy_class.rsplit(".", 1)[-1]
    state = value.state()
    if not isinstance(state, dict):
        raise ConversionError(f"{key}: chumpy {name} without a state dictionary")

    def term(term_name):
        if term_name not in state:
            raise ConversionError(f"{key}: chumpy {name} without its '{term_name}'")
        return state[term_name]

    def operand():
        return np.asarray(to_array(term("a"), f"{key}.a", depth + 1))

    if name == "Ch":
        return to_array(term("x"), key, depth + 1)
    if name == "Select":
        source = operand().ravel()
        idxs = np.asarray(to_array(term("idxs"), f"{key}.idxs", depth + 1))
        if idxs.dtype.kind not in "iu":
            raise ConversionError(f"{key}: chumpy Select with non-integer idxs ({idxs.dtype})")
        idxs = idxs.astype(np.int64).ravel()
        if idxs.size and (idxs.min() < 0 or idxs.max() >= source.size):
            raise ConversionError(
                f"{key}: chumpy Select index out of range [0, {source.size}) of its 'a'")
        result = source[idxs]
        if "preferred_shape" in state:
            shape = tuple(int(n) for n in state["preferred_shape"])
            if int(np.prod(shape)) != result.size:
                raise ConversionError(f"{key}: chumpy Select of {result.size} values cannot take "
                                      f"its preferred_shape {list(shape)}")
            result = result.reshape(shape)
        return result
    if name == "Reshape":
        source = operand()
        try:
            return source.reshape(tuple(int(n) for n in term("newshape")))
        except (TypeError, ValueError) as error:
            raise ConversionError(f"{key}: chumpy Reshape: {error}") from None
    if name == "Transpose":
        axes = state.get("axes")
        try:
            return np.transpose(operand(), None if axes is None else [int(a) for a in axes])
        except (TypeError, ValueError) as error:
            raise ConversionError(f"{key}: chumpy Transpose: {error}") from None
    raise ConversionError(f"{key}: chumpy expression {value.chumpy_class} is not supported "
                          "(supported: Ch, Select, Reshape, Transpose); please report it with "
                          "the file's origin")


# A nested list standing for more numbers than this (MANO's largest array holds 315,090) or nested
# deeper than this (MANO's arrays have at most 3 axes) is no MANO array: refused before numpy
# builds it (a small pickle can reference one row a million times).
MAX_LIST_VALUES = 10_000_000
MAX_LIST_DEPTH = 8


def check_nested_list(value, key):
    """Counts the numbers of a nested list without building it; refuses one too large or deep."""
    count = 0
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if depth > MAX_LIST_DEPTH:
            raise ConversionError(f"{key}: lists nested deeper than {MAX_LIST_DEPTH} levels: "
                                  "not a MANO array")
        for element in item:
            if isinstance(element, (list, tuple)):
                stack.append((element, depth + 1))
            else:
                count += 1
        if count > MAX_LIST_VALUES:
            raise ConversionError(f"{key}: lists of more than {MAX_LIST_VALUES:,} numbers: "
                                  "not a MANO array")


def to_array(value, key, depth=0, expected_shape=None):
    """The numeric array behind a pickled value (ndarray, chumpy expression or sparse matrix); a
    sparse matrix is checked against expected_shape before it is made dense."""
    if depth > MAX_CHUMPY_DEPTH:
        raise ConversionError(f"{key}: chumpy expressions nested deeper than {MAX_CHUMPY_DEPTH}")
    if isinstance(value, np.ndarray):
        return value
    if isinstance(value, SparseMatrix):
        return value.toarray(key, expected_shape)
    if isinstance(value, ChumpyObject):
        return chumpy_value(value, key, depth)
    if isinstance(value, (list, tuple)):
        check_nested_list(value, key)
    if isinstance(value, (list, tuple, float, int)):
        try:
            return np.asarray(value)
        except (ValueError, TypeError) as error:
            raise ConversionError(f"{key}: not an array of numbers ({error})") from None
    raise ConversionError(f"{key}: expected an array, got {type(value).__name__}")


def read_mano(path):
    try:
        # A named pipe or a device would block the open or never end.
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise ConversionError("is not a regular file (a named pipe, a device or a socket); "
                                  "give a file")
        with open(path, "rb") as stream:
            data = ManoUnpickler(stream, encoding="latin1").load()
    except OSError as error:
        raise ConversionError(f"cannot read: {error.strerror}") from None
    except ConversionError:
        raise
    except Exception as error:  # a truncated or foreign file
        raise ConversionError(f"not a MANO pickle ({type(error).__name__}: {error})") from None
    if isinstance(data, _Inert):
        data = data.state()
    if not isinstance(data, dict):
        raise ConversionError("not a MANO pickle (expected a dictionary at the top level)")
    return {str(k): v for k, v in data.items()}


def float_array(data, key, shape):
    if key not in data:
        raise ConversionError(f"missing key '{key}'")
    array = np.asarray(to_array(data[key], key, expected_shape=shape), dtype=np.float64)
    if tuple(array.shape) != tuple(shape):
        raise ConversionError(f"{key}: expected shape {list(shape)}, got {list(array.shape)}")
    if not np.all(np.isfinite(array)):
        raise ConversionError(f"{key}: non-finite value")
    return array


# Rest joints the handedness test reads (MANO order).
WRIST, INDEX_KNUCKLE, MIDDLE_KNUCKLE, PINKY_KNUCKLE = 0, 1, 4, 7
# A hand in MANO's frame gives a cosine near 1 (0.98 for the built-in hand); below 0.5 its back is
# turned more than 60 degrees away from +y (or its knuckle line runs along its fingers), and the
# joints name no hand.
MIN_HANDEDNESS_COSINE = 0.5


def geometric_handedness(v_template, j_regressor):
    """("right" / "left" / None, cosine): the hand the rest joints form. In MANO's frame the back of
    the hand faces +y for both hands (the left is the right mirrored through x = 0). The fingers
    (wrist to middle knuckle) crossed with the knuckle line (pinky to index knuckle) point to the
    back of a right hand and to the palm of a left one, however the hand is turned about y; the
    cosine is that cross product's y over the two lengths. load_rig's test is the same
    (libhandscs/hand/rig_handedness.h)."""
    joints = j_regressor @ v_template
    fingers = joints[MIDDLE_KNUCKLE] - joints[WRIST]
    knuckles = joints[INDEX_KNUCKLE] - joints[PINKY_KNUCKLE]
    lengths = np.linalg.norm(fingers) * np.linalg.norm(knuckles)
    cosine = float(np.cross(fingers, knuckles)[1] / lengths) if lengths > 0 else 0.0
    if cosine >= MIN_HANDEDNESS_COSINE:
        return "right", cosine
    if cosine <= -MIN_HANDEDNESS_COSINE:
        return "left", cosine
    return None, cosine


def check_handedness(v_template, j_regressor, hand, claim):
    """Refuses a hand label (claim: where it came from) that the geometry contradicts."""
    geometry, cosine = geometric_handedness(v_template, j_regressor)
    if geometry is None:
        raise ConversionError(
            f"the rest joints form no hand in MANO's frame (their fingers x knuckle line is at "
            f"cosine {cosine:.2f} to y; a hand's is at least {MIN_HANDEDNESS_COSINE} either way): "
            "cannot tell which hand it is")
    if geometry != hand:
        side = "+y, a right hand's back" if geometry == "right" else "-y, a left hand's palm"
        raise ConversionError(
            f"{claim}, but the geometry is a {geometry} hand: its fingers (wrist to middle "
            f"knuckle) x knuckle line (pinky to index) point to {side} in MANO's frame; "
            f"use --hand {geometry}")


MANO_KEYS = ["v_template", "f", "weights", "J_regressor", "posedirs", "shapedirs", "hands_mean"]


def check_is_mano(data):
    """A pickle of something else (another model, any dictionary) is named as such, not by the
    first array that happens to have the wrong shape."""
    if not any(key in data for key in MANO_KEYS):
        held = ", ".join(sorted(data)[:12]) or "nothing"
        raise ConversionError(f"not a MANO pickle: none of the keys {', '.join(MANO_KEYS)} "
                              f"(it holds {held})")
    if "kintree_table" in data:
        table = np.asarray(to_array(data["kintree_table"], "kintree_table"))
        joints = table.shape[1] if table.ndim == 2 else -1
        if joints != len(MANO_PARENTS):
            raise ConversionError(
                f"kintree_table: {joints} joints, MANO has {len(MANO_PARENTS)} (SMPL has 24, "
                "SMPL+H 52, SMPL-X 55): not a MANO hand model")


def convert(data, hand, claim, tips, left_fix, name):
    check_is_mano(data)
    if "v_template" not in data:
        raise ConversionError("missing key 'v_template'")
    v_template = np.asarray(to_array(data["v_template"], "v_template"), dtype=np.float64)
    if v_template.ndim != 2 or v_template.shape[1] != 3:
        raise ConversionError(f"v_template: expected shape [V, 3], got {list(v_template.shape)}")
    num_vertices = v_template.shape[0]
    if not np.all(np.isfinite(v_template)):
        raise ConversionError("v_template: non-finite value")
    if "f" not in data:
        raise ConversionError("missing key 'f'")
    faces = np.asarray(to_array(data["f"], "f")).astype(np.int64)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ConversionError(f"f: expected shape [F, 3], got {list(faces.shape)}")
    if faces.size and (faces.min() < 0 or faces.max() >= num_vertices):
        raise ConversionError(f"f: vertex index out of range [0, {num_vertices})")
    weights = float_array(data, "weights", (num_vertices, 16))
    sums = weights.sum(axis=1)
    worst = int(np.argmax(np.abs(sums - 1.0)))
    if abs(sums[worst] - 1.0) > SUM_TOLERANCE:
        raise ConversionError(f"weights[{worst}]: row sums to {sums[worst]:.6f}, expected 1")
    j_regressor = float_array(data, "J_regressor", (16, num_vertices))
    check_handedness(v_template, j_regressor, hand, claim)
    posedirs = float_array(data, "posedirs", (num_vertices, 3, 135))
    shapedirs = float_array(data, "shapedirs", (num_vertices, 3, 10)).copy()
    hands_mean = float_array(data, "hands_mean", (45,))
    if "kintree_table" in data:
        table = np.asarray(to_array(data["kintree_table"], "kintree_table")).astype(np.int64)
        parents = [int(p) if 0 <= p < 16 else -1 for p in table[0].tolist()]
        if parents != MANO_PARENTS:
            raise ConversionError(
                f"kintree_table: parents {parents} differ from MANO's {MANO_PARENTS}")
    if hand == "left" and left_fix:
        shapedirs[:, 0, :] *= -1.0
    if tips is None:
        if num_vertices != MANO_VERTICES:
            raise ConversionError(
                f"{num_vertices} vertices (MANO has {MANO_VERTICES}): "
                "pass the fingertip vertices with --tips")
        tips = MANO_TIP_VERTICES
    for i, tip in enumerate(tips):
        if not 0 <= tip < num_vertices:
            raise ConversionError(
                f"--tips[{i}]: vertex index {tip} out of range [0, {num_vertices})")

    rows, cols = np.nonzero(j_regressor)
    regressor_entries = [[int(r), int(c), float(j_regressor[r, c])] for r, c in zip(rows, cols)]
    return [
        ("format", "handscs-rig"),
        ("version", 1),
        ("units", "metres"),
        ("name", name),
        ("handedness", hand),
        ("description", f"Converted from MANO ({name}) by scripts/convert_mano.py. MANO is licence-"
                        "restricted: do not commit or redistribute this file."),
        ("parents", MANO_PARENTS),
        ("tip_vertices", [int(t) for t in tips]),
        ("hands_mean", hands_mean.tolist()),
        ("v_template", v_template.tolist()),
        ("faces", faces.tolist()),
        ("weights", weights.tolist()),
        ("j_regressor", {"shape": [16, num_vertices], "sparse": regressor_entries}),
        ("shapedirs", shapedirs.tolist()),
        ("posedirs", posedirs.tolist()),
    ]


def check_output(pickle_path, path, force):
    """Refuses an output that would destroy the input or another file, before anything is
    converted."""
    if not os.path.lexists(path):
        return
    # samefile follows symlinks and sees hard links (same device and inode); the pickle exists, as
    # it has been read.
    if os.path.exists(path) and os.path.samefile(pickle_path, path):
        raise OutputError(f"is the input pickle {pickle_path}; name another output file")
    if os.path.isdir(path):
        raise OutputError("is a folder; name a rig file to write")
    if not force:
        raise OutputError("exists; pass --force to replace it")


def write_rig(entries, path):
    """One key per line; floats as Python's shortest round-trip repr (exact float64). Written to
    path.tmp.PID and renamed over path, so path is the old file or the whole new one; the temporary
    is removed on every failure (a full disk, an interrupt)."""
    lines = [f"  {json.dumps(key)}: {json.dumps(value, separators=(',', ':'), allow_nan=False)}"
             for key, value in entries]
    text = "{\n" + ",\n".join(lines) + "\n}\n"
    temp = f"{path}.tmp.{os.getpid()}"
    created = False
    try:
        with open(temp, "w", encoding="utf-8") as stream:
            created = True
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temp, path)
        created = False
    finally:
        if created:
            os.remove(temp)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("pickle", help="MANO_RIGHT.pkl or MANO_LEFT.pkl")
    parser.add_argument("output", help="rig file to write (JSON, docs/RIG_FORMAT.md)")
    parser.add_argument("--hand", choices=["right", "left"],
                        help="handedness (default: from the file name, MANO_RIGHT / MANO_LEFT)")
    parser.add_argument("--tips", help="fingertip vertex ids thumb,index,middle,ring,pinky "
                                       "(default for MANO's 778 vertices: 745,317,445,556,673)")
    parser.add_argument("--no-left-shapedirs-fix", action="store_true",
                        help="do not negate shapedirs[:, 0, :] of a left hand (file already fixed)")
    parser.add_argument("--name",
                        help="rig name (default: the pickle's file name without extension)")
    parser.add_argument("--force", action="store_true",
                        help="replace an existing output file (never the input pickle)")
    args = parser.parse_args(argv)

    stem = os.path.splitext(os.path.basename(args.pickle))[0]
    hand = args.hand
    if hand is None:
        if "LEFT" in stem.upper():
            hand = "left"
        elif "RIGHT" in stem.upper():
            hand = "right"
        else:
            print(f"convert_mano.py: {args.pickle}: cannot tell the hand from the file name; "
                  "pass --hand right or --hand left", file=sys.stderr)
            return 2
    tips = None
    if args.tips:
        try:
            tips = [int(t) for t in args.tips.split(",")]
        except ValueError:
            tips = []
        if len(tips) != 5:
            print("convert_mano.py: --tips needs 5 comma-separated vertex ids", file=sys.stderr)
            return 2
    try:
        data = read_mano(args.pickle)
        check_output(args.pickle, args.output, args.force)
        claim = f"--hand {hand}" if args.hand else f"the file name says {hand}"
        entries = convert(data, hand, claim, tips, not args.no_left_shapedirs_fix,
                          args.name or stem)
        write_rig(entries, args.output)
    except ConversionError as error:
        print(f"convert_mano.py: {args.pickle}: {error}", file=sys.stderr)
        return 1
    except OutputError as error:
        print(f"convert_mano.py: {args.output}: {error}", file=sys.stderr)
        return 1
    except OSError as error:
        print(f"convert_mano.py: {args.output}: cannot write ({error.strerror})", file=sys.stderr)
        return 1
    print(f"convert_mano.py: wrote {args.output} ({hand} hand). MANO is licence-restricted: "
          "keep this file out of version control.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
