#!/usr/bin/env bash
# Installs every Debian 12 package the project needs to build, test and run. Idempotent: when all
# packages are present it only runs dpkg-query (well under a second) and exits.
set -euo pipefail

packages=(
  build-essential cmake ccache pkg-config
  ninja-build             # scripts/build.sh's generator when present (builds side by side)
  libtorch-dev            # LibTorch 1.13 (CPU): autograd for encoder, generator, decoders
  libopenblas0-openmp     # BLAS for LibTorch: 100 GFLOP/s/core instead of the 6 GFLOP/s reference BLAS
  libgloo-dev             # headers of the Gloo collectives LibTorch's c10d uses (data-parallel training)
  libopencv-dev           # image and video I/O
  libjpeg62-turbo-dev     # libjpeg itself: JPEG damage from its own warnings (core/jpeg_damage.h)
  nlohmann-json3-dev      # configs, annotations
  libcli11-dev            # command lines
  libspdlog-dev           # logging
  catch2                  # tests (v2 API)
  python3 python3-numpy   # MANO converter and its test reference
  python3-matplotlib      # handscs-bench charts (scripts/plot_sweep.py), tools/study/ablation_table.py
  python3-sklearn         # handscs-features' t-SNE plots and the check of its metrics (scripts/plot_features.py)
  libcpp-httplib-dev      # handscs-view's HTTP server
  chromium                # handscs-view's browser test (headless, driven by puppeteer-core from npm)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done"
