#!/usr/bin/env bash
# Installs radlab's build and run dependencies from Debian 12 packages. Idempotent: installs only
# what is missing, and does nothing (not even apt-get update) when everything is present.
# Needs root for apt-get; as another user it uses sudo when available, else says what to run.
set -euo pipefail

packages=(
  build-essential cmake git pkg-config
  libglm-dev libembree-dev libopenexr-dev libceres-dev libeigen3-dev libtbb-dev
  libcli11-dev libtomlplusplus-dev libpng-dev nlohmann-json3-dev libboost-dev
  libgtest-dev libbenchmark-dev clang-format
  libcgal-dev  # scene/triangulate.cpp (header-only)
  libboost-dev  # Boost.Geometry R-tree in scene/overlap.cpp (header-only)
  libssl-dev  # SHA-256 of loaded plugins (solvers/plugin_loader.cpp)
  python3 python3-matplotlib python3-numpy python3-pandas
  snakemake  # workflow/Snakefile and its test (76 packages, 682 MB with python3-azure)
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
if [ "$(id -u)" -eq 0 ]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "install-deps: not root and no sudo. As root, run:" >&2
  echo "  apt-get update && apt-get install -y ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -qq
"${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
