#!/usr/bin/env python3
"""Builds the LPIPS weight file HandSCS loads (a torch.save dict with the official LPIPS key names).

Sources (download them yourself; this script makes no network access):
  alex: torchvision's ImageNet AlexNet   alexnet-owt-7be5be79.pth  (keys features.{0,3,6,8,10}.{weight,bias})
        LPIPS v0.1 linear layers         alex.pth                  (keys lin0..lin4.model.1.weight)
  vgg:  torchvision's ImageNet VGG16     vgg16-397923af.pth        (keys features.{0,2,...,28}.{weight,bias})
        LPIPS v0.1 linear layers         vgg.pth                   (keys lin0..lin4.model.1.weight)

Output keys: net.sliceS.I.{weight,bias} (I = the layer index in torchvision's `features`) and
linT.model.1.weight, all float32; see docs/METRICS.md. Needs python3 and torch (Debian: python3-torch).

Usage:
  scripts/convert_lpips_weights.py --net alex --backbone alexnet-owt-7be5be79.pth --lin alex.pth \
      --out lpips_alex_v0.1.pt
"""
import argparse
import hashlib
import sys

try:
    import torch
except ImportError:
    sys.exit(f"error: {sys.executable} has no torch module; install python3-torch (Debian) and run "
             "this script with that python, e.g. /usr/bin/python3 scripts/convert_lpips_weights.py")

# torchvision `features` index of each conv, grouped by the LPIPS slice (tap) it belongs to, with
# its weight shape (out, in, k, k).
NETS = {
    "alex": [
        [(0, (64, 3, 11, 11))],
        [(3, (192, 64, 5, 5))],
        [(6, (384, 192, 3, 3))],
        [(8, (256, 384, 3, 3))],
        [(10, (256, 256, 3, 3))],
    ],
    "vgg": [
        [(0, (64, 3, 3, 3)), (2, (64, 64, 3, 3))],
        [(5, (128, 64, 3, 3)), (7, (128, 128, 3, 3))],
        [(10, (256, 128, 3, 3)), (12, (256, 256, 3, 3)), (14, (256, 256, 3, 3))],
        [(17, (512, 256, 3, 3)), (19, (512, 512, 3, 3)), (21, (512, 512, 3, 3))],
        [(24, (512, 512, 3, 3)), (26, (512, 512, 3, 3)), (28, (512, 512, 3, 3))],
    ],
}


class ConversionError(Exception):
    pass


def load_state_dict(path):
    try:
        state = torch.load(path, map_location="cpu")
    except Exception as e:  # noqa: BLE001 - report any reader failure with the file name
        raise ConversionError(f"{path}: cannot read ({e})")
    if hasattr(state, "state_dict") and not isinstance(state, dict):
        state = state.state_dict()
    if not isinstance(state, dict):
        raise ConversionError(f"{path}: expected a state dict, got {type(state).__name__}")
    # Files saved from nn.DataParallel carry a "module." prefix.
    return {(k[len("module."):] if k.startswith("module.") else k): v for k, v in state.items()}


def take(state, path, key, shape):
    if key not in state:
        known = ", ".join(sorted(state)[:8])
        raise ConversionError(f"{path}: missing key '{key}' (file has: {known}{', ...' if len(state) > 8 else ''})")
    tensor = state[key]
    if not torch.is_tensor(tensor):
        raise ConversionError(f"{path}: key '{key}': expected a tensor, got {type(tensor).__name__}")
    if tuple(tensor.shape) != tuple(shape):
        raise ConversionError(f"{path}: key '{key}': expected shape {list(shape)}, got {list(tensor.shape)}")
    tensor = tensor.detach().to(torch.float32).clone().contiguous()
    if not torch.isfinite(tensor).all():
        raise ConversionError(f"{path}: key '{key}': holds NaN or infinite values")
    return tensor


def convert(net, backbone_path, lin_path):
    if net not in NETS:
        raise ConversionError(f"unknown net '{net}' (known: {', '.join(NETS)})")
    backbone = load_state_dict(backbone_path)
    lins = load_state_dict(lin_path)
    out = {}
    for slice_index, convs in enumerate(NETS[net], start=1):
        for layer, shape in convs:
            prefix = f"net.slice{slice_index}.{layer}"
            out[prefix + ".weight"] = take(backbone, backbone_path, f"features.{layer}.weight", shape)
            out[prefix + ".bias"] = take(backbone, backbone_path, f"features.{layer}.bias", shape[:1])
    for t, convs in enumerate(NETS[net]):
        channels = convs[-1][1][0]
        key = f"lin{t}.model.1.weight"
        out[key] = take(lins, lin_path, key, (1, channels, 1, 1))
        if (out[key] < 0).any():
            print(f"warning: {lin_path}: {key} has negative weights (LPIPS v0.1 lin weights are >= 0)",
                  file=sys.stderr)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--net", default="alex", choices=sorted(NETS), help="backbone (default alex)")
    parser.add_argument("--backbone", required=True, help="torchvision ImageNet weights (.pth)")
    parser.add_argument("--lin", required=True, help="LPIPS v0.1 lin weights (alex.pth / vgg.pth)")
    parser.add_argument("--out", required=True, help="output file, e.g. lpips_alex_v0.1.pt")
    args = parser.parse_args(argv)
    try:
        weights = convert(args.net, args.backbone, args.lin)
    except ConversionError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    torch.save(weights, args.out)
    with open(args.out, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    print(f"wrote {args.out}: LPIPS {args.net}, {len(weights)} tensors, sha256 {digest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
