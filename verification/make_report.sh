#!/usr/bin/env bash
# trainsim's verification report: run every thesis case afresh with the built trainsim,
# compare each figure with the thesis's number and its tolerance, draw the figures, and
# write verification/REPORT.md and verification/report/*.png (verification/make_report.py).
#
#   bash verification/make_report.sh            write REPORT.md and its figures
#   bash verification/make_report.sh --check    compare only (nothing written in the repository)
#
# Runs go to build/verification-report/ (--work DIR to change it). Environment: TRAINSIM
# (default: build/trainsim, the Release build). Exit status: 0 every must-pass comparison
# passed, 1 some must-pass comparison failed, 2 a run or a figure could not be made.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
exec /usr/bin/python3 "$root/verification/make_report.py" --trainsim "${TRAINSIM:-$root/build/trainsim}" "$@"
