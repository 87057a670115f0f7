"""The head the command-line check scripts share (tests/cli/check_*.py).

    from clicheck import check, run, failures, finish

- `check(what, ok, detail='')` prints "ok   WHAT" or "FAIL WHAT  [detail]" and keeps the failures;
- `run(args)` runs the trainsim named by the script's first argument (sys.argv[1]) with
  `args`, capturing its output as text (`timeout` seconds at the most, 300 by default);
- `finish()` ends the script: exit 1 when a check failed, else 0;
- `datasets(path)` reads every dataset of an HDF5 file into a dict {path: value}.

A script run as `python3 tests/cli/check_X.py` finds this module beside it (the script's
folder is the first entry of sys.path).
"""
import subprocess
import sys

EXE = sys.argv[1] if len(sys.argv) > 1 else None
failures = []


def check(what, ok, detail=''):
    print(('ok   ' if ok else 'FAIL ') + what + ('' if ok or not detail else f'  [{detail}]'))
    if not ok:
        failures.append(what)


def run(args, timeout=300, **kw):
    return subprocess.run([EXE] + args, capture_output=True, text=True, timeout=timeout, **kw)


def finish(summary=False):
    """Exit 1 if a check failed (with summary, first print how many), else 0."""
    if failures and summary:
        print(f'{len(failures)} check(s) failed')
    sys.exit(1 if failures else 0)


def datasets(path):
    """Every dataset of the HDF5 file at path, as {its path in the file: its values}."""
    import h5py
    d = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda k, v: d.__setitem__(k, v[()]) if isinstance(v, h5py.Dataset) else None)
    return d
