#!/usr/bin/env bash
# Set up (install what is missing, build in Release) and run the main job on the
# bundled deck; the HDF5 history goes to results/.
#
#   bash scripts/run-main.sh
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

bash scripts/setup.sh

deck=inputs/gregory_harris_munro.nml

mkdir -p results
out="results/$(basename "$deck" .nml).h5"
build/trainsim run "$deck" -o "$out"
echo "run-main.sh: history of $deck written to $repo_root/$out"
png="${out%.h5}.png"
/usr/bin/python3 verification/plot_history.py "$out" --element mesh --out "$png" > /dev/null
echo "run-main.sh: transmission error, mesh force and phase plane drawn in $repo_root/$png"
