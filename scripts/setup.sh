#!/usr/bin/env bash
# Install what trainsim needs (Debian packages, see /work/shared/STACK.md) if anything
# is missing, then configure and build trainsim.
#
#   bash scripts/setup.sh            Release build into build/
#   bash scripts/setup.sh --debug    Debug build into build-debug/
#
# Works from any directory. When every package is present, no apt command is run,
# so re-running it is cheap (a CMake re-configure and an incremental build).
set -euo pipefail

usage() {
  cat <<'EOF'
usage: bash scripts/setup.sh [--debug]

Installs the missing Debian packages (apt-get, as root or through sudo), then builds
trainsim with CMake:
  (default)   Release configuration into build/
  --debug     Debug configuration (run-time checks, FP traps) into build-debug/
EOF
}

build_type=Release
build_dir=build
while [ $# -gt 0 ]; do
  case "$1" in
    --debug) build_type=Debug; build_dir=build-debug ;;
    --release) build_type=Release; build_dir=build ;;
    -h|--help) usage; exit 0 ;;
    *) echo "setup.sh: error: unknown option '$1'" >&2; usage >&2; exit 2 ;;
  esac
  shift
done

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

# --- Debian packages --------------------------------------------------------
packages=(
  gfortran cmake make
  libsundials-dev libsundials-fortran-dev libhdf5-dev hdf5-tools
  libopenmpi-dev openmpi-bin liblapack-dev libblas-dev
  python3-numpy python3-scipy python3-h5py python3-matplotlib
)

if command -v dpkg-query >/dev/null 2>&1; then
  missing=()
  for p in "${packages[@]}"; do
    status="$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)"
    if [ "$status" != "install ok installed" ]; then
      missing+=("$p")
    fi
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "setup.sh: installing missing packages: ${missing[*]}"
    if [ "$(id -u)" -eq 0 ]; then
      sudo=()
    elif command -v sudo >/dev/null 2>&1; then
      sudo=(sudo)
    else
      echo "setup.sh: error: packages are missing (${missing[*]}) and this is neither root nor has sudo" >&2
      exit 1
    fi
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y "${missing[@]}"
  fi
else
  echo "setup.sh: warning: dpkg-query not found (not Debian?); skipping the package check" >&2
fi

# --- build -------------------------------------------------------------------
jobs="$(nproc 2>/dev/null || echo 2)"
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE="$build_type"
cmake --build "$build_dir" -j"$jobs"
echo "setup.sh: trainsim ($build_type) is at $repo_root/$build_dir/trainsim"
