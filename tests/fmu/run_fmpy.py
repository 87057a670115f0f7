#!/usr/bin/python3
"""CTest case fmu_fmpy: `trainsim fmu` checked by an independent importer, FMPy.

    run_fmpy.py TRAINSIM_EXE SOURCE_DIR WORK_DIR

FMPy is a test tool from PyPI, installed into a venv made with --system-site-packages
(numpy, lxml, attrs, h5py are Debian's; FMPy and its small pure-Python dependencies come
with --no-deps); without the network the case is skipped (exit 77) and says why. Then, in
the venv, check_fmu.py: FMPy's validation of the FMU of the Table 5.5 rig; FMPy's
co-simulation against `trainsim run` at every communication point, with communication
steps larger and smaller than the contact events' spacing, rk4 and cvode-bdf; an input
torque step through the FMU's input against a run of the deck with that step load; a
state saved and restored mid-run continues bit for bit; bad --input is refused.
"""
import os
import shutil
import subprocess
import sys

SKIP = 77
PYPI = ["fmpy==0.3.32", "jinja2", "markupsafe", "msgpack", "lark"]


def main():
    exe, source, work = sys.argv[1:4]
    venv = os.path.join(work, "venv")
    os.makedirs(work, exist_ok=True)
    py = os.path.join(venv, "bin", "python")
    if subprocess.run([py, "-c", "import fmpy"], capture_output=True).returncode if os.path.exists(py) else True:
        shutil.rmtree(venv, ignore_errors=True)
        r = subprocess.run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", venv],
                           capture_output=True, text=True)
        if r.returncode:
            print(r.stdout, r.stderr)
            return 1
        r = subprocess.run([py, "-m", "pip", "install", "--disable-pip-version-check", "--timeout", "20",
                            "--retries", "1", "--no-deps"] + PYPI, capture_output=True, text=True)
        if r.returncode:
            print(r.stdout[-1500:], r.stderr[-1500:])
            print("SKIPPED: FMPy (a test tool from PyPI) could not be installed, so the FMU was not "
                  "checked by an independent importer")
            return SKIP
    env = dict(os.environ, TRAINSIM_EXE=exe, TRAINSIM_SOURCE=source)
    return subprocess.run([py, os.path.join(source, "tests", "fmu", "check_fmu.py"), work], env=env).returncode


if __name__ == "__main__":
    sys.exit(main())
