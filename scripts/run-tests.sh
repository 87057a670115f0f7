#!/usr/bin/env bash
# Set up, then run the whole test suite on the Release build (build/) and on the
# Debug build (build-debug/, run-time checks and floating-point traps on).
#
#   bash scripts/run-tests.sh                  Release and Debug
#   bash scripts/run-tests.sh --release-only   Release only
#
# Exits non-zero if any ctest run fails (both runs are made either way).
set -euo pipefail

debug=1
while [ $# -gt 0 ]; do
  case "$1" in
    --release-only) debug=0 ;;
    -h|--help)
      echo "usage: bash scripts/run-tests.sh [--release-only]"
      exit 0 ;;
    *) echo "run-tests.sh: error: unknown option '$1'" >&2; exit 2 ;;
  esac
  shift
done

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo_root"

status=0
failed=()

bash scripts/setup.sh
if ! ctest --test-dir build --output-on-failure; then
  status=1
  failed+=(Release)
fi

if [ "$debug" -eq 1 ]; then
  bash scripts/setup.sh --debug
  if ! ctest --test-dir build-debug --output-on-failure; then
    status=1
    failed+=(Debug)
  fi
fi

if [ "$status" -ne 0 ]; then
  echo "run-tests.sh: FAILED (${failed[*]})" >&2
else
  echo "run-tests.sh: all tests passed"
fi
exit "$status"
