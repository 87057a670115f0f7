#!/usr/bin/python3
"""CTest case python_package: the Python package installed from the build tree into a
fresh virtual environment, then its tests (python/tests) run with pytest.

    run_python_package.py BUILD_DIR SOURCE_DIR TRAINSIM_EXE WORK_DIR

The venv is made with --system-site-packages (numpy, h5py and matplotlib come from
Debian); the package is installed with `pip install --no-build-isolation --no-deps
BUILD_DIR/python` (offline: setuptools is Debian's). pytest is a test tool from PyPI:
when it cannot be installed (no network), the case is skipped (exit 77) and says why.
"""
import os
import shutil
import subprocess
import sys

SKIP = 77


def run(cmd, **kw):
    print("+", " ".join(map(str, cmd)), flush=True)
    return subprocess.run(cmd, text=True, capture_output=True, **kw)


def main():
    build, source, exe, work = sys.argv[1:5]
    venv = os.path.join(work, "venv")
    shutil.rmtree(venv, ignore_errors=True)
    os.makedirs(work, exist_ok=True)
    r = run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", venv])
    if r.returncode:
        print(r.stdout, r.stderr)
        return 1
    py = os.path.join(venv, "bin", "python")
    r = run([py, "-m", "pip", "install", "--no-build-isolation", "--no-deps", "--no-index",
             os.path.join(build, "python")])
    print(r.stdout[-2000:], r.stderr[-2000:])
    if r.returncode:
        return 1
    # the installed package must load from the venv, not from the build tree
    r = run([py, "-c", "import trainsim; print(trainsim.__version__, trainsim.library_path)"], cwd=work)
    print(r.stdout, r.stderr)
    if r.returncode or venv not in r.stdout:
        print("the package did not load from the venv")
        return 1
    have = run([py, "-c", "import pytest"], cwd=work).returncode == 0
    if not have:
        r = run([py, "-m", "pip", "install", "--disable-pip-version-check", "--timeout", "20", "--retries", "1",
                 "pytest"])
        if r.returncode:
            print(r.stdout[-1500:], r.stderr[-1500:])
            print("SKIPPED: pytest (a test tool from PyPI) could not be installed into the venv, "
                  "so the package's tests were not run; the package itself installed and imported")
            return SKIP
    env = dict(os.environ, TRAINSIM_EXE=exe, TRAINSIM_SOURCE=source, MPLBACKEND="Agg",
               PATH=os.path.join(venv, "bin") + os.pathsep + os.environ.get("PATH", ""))
    env.pop("PYTHONPATH", None)
    env.pop("TRAINSIM_LIBRARY", None)
    r = subprocess.run([py, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--basetemp", os.path.join(work, "tmp"),
                        os.path.join(source, "python", "tests")], cwd=work, env=env)
    return r.returncode


if __name__ == "__main__":
    sys.exit(main())
