#!/usr/bin/env bash
# Run every verification deck of verification/README.md and draw its figures.
#
#   verification/run_all.sh [RESULTS_DIR]
#
# RESULTS_DIR (default: build/verification-results, ignored by git) receives
# for each deck NAME:
#   NAME.h5          the history           (trainsim run DECK -o NAME.h5)
#   NAME.log         the run's summary     (stdout + stderr of the run)
#   NAME.modes.txt   the linearised modes  (trainsim modes DECK)
#   NAME.png         the figures of its clearance element, from plot_history.py
#                    (NAME_<id>.png, one per element, when the deck has several
#                    clearance elements, or none: then every element is drawn)
#   NAME.plot.txt    the event-table summary printed by plot_history.py
# plus case2_smith*, a copy of Chapter III case II with restitution_law = 'smith'.
#
# Environment: TRAINSIM (default: build/trainsim), PYTHON (default: the first of
# python3, /usr/bin/python3 that has h5py, numpy and matplotlib).
# Exit status: 0 if every run and every plot succeeded, 1 otherwise.
set -u

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
trainsim="${TRAINSIM:-$root/build/trainsim}"
out="${1:-$root/build/verification-results}"

case "$trainsim" in /*) ;; *) trainsim="$PWD/$trainsim" ;; esac
if [ ! -x "$trainsim" ]; then
  echo "run_all.sh: error: no trainsim executable at '$trainsim' (build it, or set TRAINSIM)" >&2
  exit 2
fi

python=""
for p in "${PYTHON:-}" python3 /usr/bin/python3; do
  [ -n "$p" ] || continue
  if "$p" -c 'import h5py, numpy, matplotlib' >/dev/null 2>&1; then python="$p"; break; fi
done
if [ -z "$python" ]; then
  echo "run_all.sh: warning: no Python with h5py, numpy and matplotlib: runs only, no figures" >&2
fi

mkdir -p "$out"
out="$(cd "$out" && pwd)"

decks=(
  verification/table5_1/table5_1.nml
  verification/table5_2/table5_2.nml
  verification/table5_3/table5_3.nml
  verification/table5_4/table5_4.nml
  verification/chapter3/case1.nml
  verification/chapter3/case2.nml
  verification/chapter3/case3.nml
  inputs/gregory_harris_munro.nml
  inputs/two_clearance.nml
)

# Chapter III case II with Smith's restitution (eq. 3.20): a temporary copy
smith="$out/case2_smith.nml"
sed "s#half_backlash = 0.001 /#half_backlash = 0.001, restitution_law = 'smith' /#" \
  "$root/verification/chapter3/case2.nml" > "$smith"
if grep -q "restitution_law = 'smith'" "$smith"; then
  decks+=("$smith")
else
  echo "run_all.sh: warning: could not make the Smith variant of case II (deck changed?); skipped" >&2
  rm -f "$smith"
fi

failed=()
printf '%-22s %-6s %s\n' deck run figures
for d in "${decks[@]}"; do
  case "$d" in /*) deck="$d" ;; *) deck="$root/$d" ;; esac
  name="$(basename "$deck" .nml)"
  # run inside the results directory, so that nothing is written into the repository
  if (cd "$out" && "$trainsim" run "$deck" -o "$name.h5") > "$out/$name.log" 2>&1; then
    run=ok
  else
    run=FAILED
    failed+=("$name (run)")
  fi
  (cd "$out" && "$trainsim" modes "$deck") > "$out/$name.modes.txt" 2>&1 || true
  figs=-
  if [ "$run" = ok ] && [ -n "$python" ]; then
    if "$python" "$root/verification/plot_history.py" "$out/$name.h5" --element all --out "$out/$name.png" \
        > "$out/$name.plot.txt" 2>&1; then
      figs="$(sed -n 's#^  wrote .*/##p' "$out/$name.plot.txt" | tr '\n' ' ')"
    else
      figs=FAILED
      failed+=("$name (plot)")
    fi
  fi
  printf '%-22s %-6s %s\n' "$name" "$run" "$figs"
done

echo "results in $out"
if [ ${#failed[@]} -gt 0 ]; then
  echo "run_all.sh: failed: ${failed[*]}" >&2
  exit 1
fi
exit 0
