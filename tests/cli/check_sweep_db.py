#!/usr/bin/python3
"""The sweep file as a database (issue 20, item 10). One case per CTest entry:

    /usr/bin/python3 tests/cli/check_sweep_db.py <trainsim> <case>

cases:
  race         two identical sweeps started at once on one -o, 50 times: the file is
               never damaged; one completes and the other refuses (the writer lock), or
               both complete; either way the file equals an uninterrupted sweep's bits
  kill_random  a sweep with failing runs killed with kill -9 at 20 random instants (20
               fresh trials), then the same command: it makes exactly the runs not yet
               committed (a committed run keeps its wall-time bits), and the file's
               statuses, metrics and messages equal an uninterrupted sweep's bits
  paths        -o onto /dev/null, a directory, a FIFO, a dangling symbolic link, '-':
               exit 2 naming the kind of path, nothing replaced or created
  fingerprint  an edited table file or deck value: exit 2 "holds another sweep" naming what
               differs; a comment or blanks added to the deck: the sweep resumes
  status       statuses set to invalid values (-1, 7): those runs are made again, the
               file ends equal to an uninterrupted sweep
  signals      SIGINT / SIGTERM part-way: exit 130 / 143, a message with the runs recorded
               and "the same command resumes"; the same command completes the sweep equal
               to an uninterrupted one; on 2 MPI ranks (when mpirun is there) SIGTERM to
               the ranks: mpirun exits 143, and the resumed file is equal too; Ctrl-C to
               mpirun (SIGINT to its process group): rank 0's message, the runs it names
  export       trainsim export on a sweep file: exit 2, "a sweep file", names trainsim plot
  diskfull     (root, a tmpfs; else exit 77 = skipped) a sweep onto a full disk: exit 2 "No
               space left on device", no FILE.part left; the disk filling while runs are
               recorded: exit 2, no crash; the same command after space is freed completes
               the sweep equal to an uninterrupted one, every failed run with its own message
"""

import os
import random
import re
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

TIMEOUT = 600

GHM = """&run  title = 'GHM rig (sweep-file tests)'
      t_end = 0.02, dt = 8.0e-6, integrator = 'rk4', output_interval = 8.0e-6 /
&node id = 'n1', type = 'inertia', inertia = 100.0 /
&node id = 'n2', type = 'inertia', inertia = 0.987 /
&node id = 'n3', type = 'inertia', inertia = 0.987 /
&node id = 'n4', type = 'inertia', inertia = 100.0 /
&element id = 'shaft1', type = 'shaft', stiffness = 32000.0 /
&element id = 'mesh', type = 'spur_gear',
         stiffness = 234500.0, rb_driver = 3.7588, rb_driven = 3.7588, teeth = 32,
         contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005 /
&element id = 'shaft3', type = 'shaft', stiffness = 32000.0 /
&load node = 'n1', quantity = 'speed', value = 95.2295 /
&load node = 'n4', value = -798.8 /
&initial node = 'all', speed = 95.2295 /
"""
# 10 mesh frequencies x 2 mesh stiffnesses: the 1e13 runs fail (event flood), each with its message
FAILING = GHM + """&sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645, count = 10 /
&sweep parameter = 'mesh.settle_cycles', values = 50 /
&sweep parameter = 'mesh.measure_cycles', values = 100 /
&sweep parameter = 'mesh.stiffness', values = 234500.0, 1e13 /
"""
# a tiny sweep: 6 runs of the Table 5.3 pair, a few ms each
TINY = """&run  title = 'sweep: Table 5.3 grid', t_end = 2.0e-4, dt = 5.0e-7, integrator = 'rk4' /
&node id = 'driver', type = 'inertia', inertia = 7.537e-3 /
&node id = 'driven', type = 'inertia', inertia = 10.082 /
&element id = 'mesh', type = 'spur_gear',
         stiffness = 18.03e6, rb_driver = 1.6445, rb_driven = 1.6445, teeth = 28,
         contact_ratio = 1.6380, approach_angle = 0.1838, half_backlash = 0.001 /
&initial node = 'driver', speed = 10.0 /
&sweep parameter = 'mesh.half_backlash', values = 0.0005, 0.001, 0.002 /
&sweep parameter = 'mesh.mesh_frequency', values = 30.0, 45.0 /
"""
# a deck that reads a table file
TABLE = """&run  t_end = 0.02, dt = 1.0e-5, integrator = 'rk4' /
&node id = 'shaft', type = 'inertia', inertia = 0.02, damping = 0.05 /
&node id = 'load', type = 'inertia', inertia = 1.0, damping = 0.5 /
&element id = 'coupling', type = 'clearance_coupling', left = 'shaft', right = 'load',
         clearance = 0.02, stiffness = 5.0e3, contact_damping = 2.0 /
&load node = 'shaft', kind = 'ramp', value0 = 0.0, value1 = 20.0, t0 = 0.0, t1 = 0.1 /
&load node = 'load', kind = 'table', table_file = 'tab.txt' /
&sweep parameter = 'coupling.clearance', values = 0.01, 0.02, 0.03, 0.04 /
"""

failures = []


def check(what, cond, detail=""):
    print(("ok   " if cond else "FAIL ") + what + (("  [" + detail[:400] + "]") if detail and not cond else ""),
          flush=True)
    if not cond:
        failures.append(what)


def run(cmd, cwd, **kw):
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT, **kw)


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def content(path):
    """Statuses, metrics, parameter values and messages of a sweep file (None if unreadable)."""
    try:
        with h5py.File(path, "r") as f:
            out = {"runs/status": f["runs/status"][:], "runs/message": f["runs/message"].asstr()[:],
                   "parameters/values": f["parameters/values"][:]}
            for g in ("elements", "nodes"):
                for k in f[g]:
                    if k not in ("ids", "types"):
                        out[g + "/" + k] = f[g][k][:]
            return out
    except (OSError, KeyError) as e:
        return None


def same(a, b):
    """(equal to the bit, first dataset that differs)."""
    if a is None or b is None:
        return False, "unreadable"
    if a.keys() != b.keys():
        return False, "different datasets"
    for k in a:
        x, y = a[k], b[k]
        if x.dtype.kind == "f":
            x, y = x.view(np.uint64), y.view(np.uint64)
        if not np.array_equal(x, y):
            return False, k
    return True, ""


def leftovers(tmp):
    return [n for n in os.listdir(tmp) if n.endswith(".part") or n.endswith(".lock")]


def case_race(exe, tmp):
    write(os.path.join(tmp, "tiny.nml"), TINY)
    r = run([exe, "sweep", "tiny.nml", "-o", "ref.h5"], tmp)
    check("reference sweep exits 0", r.returncode == 0, r.stderr)
    ref = content(os.path.join(tmp, "ref.h5"))
    damaged, bad_exits, refusals, later_bad = 0, 0, 0, 0
    for trial in range(50):
        for n in ("sw.h5",):
            if os.path.exists(os.path.join(tmp, n)):
                os.remove(os.path.join(tmp, n))
        cmd = [exe, "sweep", "tiny.nml", "-o", "sw.h5"]
        a = subprocess.Popen(cmd, cwd=tmp, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        b = subprocess.Popen(cmd, cwd=tmp, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        ea, eb = a.communicate(timeout=TIMEOUT)[1], b.communicate(timeout=TIMEOUT)[1]
        codes = sorted([a.returncode, b.returncode])
        refused = [e for c, e in ((a.returncode, ea), (b.returncode, eb)) if c == 2]
        if codes == [0, 2] and "another trainsim sweep is writing it" in refused[0]:
            refusals += 1
        elif codes != [0, 0]:
            bad_exits += 1
            print(f"  trial {trial + 1}: exits {a.returncode} {b.returncode}: {ea.strip()} | {eb.strip()}")
        ok, which = same(ref, content(os.path.join(tmp, "sw.h5")))
        if not ok:
            damaged += 1
            print(f"  trial {trial + 1}: the file differs from the reference ({which})")
        r = run(cmd, tmp)
        if r.returncode != 0 or "sweep: 0 run(s) made" not in r.stdout:
            later_bad += 1
        if leftovers(tmp):
            damaged += 1
            print(f"  trial {trial + 1}: left {leftovers(tmp)}")
    print(f"  {refusals} of 50 trials: one sweep refused while the other wrote (the rest: both completed)")
    check("50 trials: every pair ends as (0, 2 'another trainsim sweep is writing it') or (0, 0)", bad_exits == 0)
    check("50 trials: the file always equals the uninterrupted sweep's bits, no .part or .lock left", damaged == 0)
    check("50 trials: the same command afterwards finds the sweep complete (exit 0, 0 runs made)", later_bad == 0)
    return 0


def case_kill_random(exe, tmp):
    write(os.path.join(tmp, "f.nml"), FAILING)
    t0 = time.monotonic()
    r = run([exe, "sweep", "f.nml", "-o", "ref.h5"], tmp)
    wall = time.monotonic() - t0
    check("reference sweep exits 1 (some runs fail)", r.returncode == 1, r.stderr)
    ref = content(os.path.join(tmp, "ref.h5"))
    n = len(ref["runs/status"])
    rng = random.Random(20)
    cmd = [exe, "sweep", "f.nml", "-o", "k.h5", "--progress", "0"]
    path = os.path.join(tmp, "k.h5")
    unreadable, bad_status, not_once, differ, killed = 0, 0, 0, 0, 0
    ks = []
    for trial in range(20):
        if os.path.exists(path):
            os.remove(path)
        at = rng.uniform(0.0, wall)
        p = subprocess.Popen(cmd, cwd=tmp, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            p.wait(timeout=at)
        except subprocess.TimeoutExpired:
            p.send_signal(signal.SIGKILL)
            p.wait()
            killed += 1
        k, before = 0, None
        if os.path.exists(path):
            try:
                with h5py.File(path, "r") as f:
                    status = f["runs/status"][:]
                    before = (status != 0, f["runs/wall_time"][:].view(np.uint64))
                    f["runs/message"].asstr()[:][status != 0]
                k = int(np.count_nonzero(status))
                if not set(status.tolist()) <= {0, 1, 2}:
                    bad_status += 1
            except (OSError, KeyError):
                unreadable += 1
                continue
        ks.append(k)
        r = run(cmd, tmp)
        made = re.search(r"sweep: (\d+) run\(s\) made", r.stdout)
        once = r.returncode == 1 and made is not None and int(made.group(1)) == n - k
        if before is not None:
            with h5py.File(path, "r") as f:
                after = f["runs/wall_time"][:].view(np.uint64)
            once = once and np.array_equal(after[before[0]], before[1][before[0]])
        if not once:
            not_once += 1
            print(f"  trial {trial + 1} (kill at {at:.3f} s, {k} committed): {r.returncode} {r.stdout.strip()}")
        if not same(ref, content(path))[0]:
            differ += 1
            print(f"  trial {trial + 1} (kill at {at:.3f} s): differs in {same(ref, content(path))[1]}")
    print(f"  uninterrupted: {wall:.2f} s; {killed} of 20 trials killed before the sweep ended; runs committed "
          f"at each kill: {ks}")
    check("after every kill the file (if made) opens and its committed messages read", unreadable == 0)
    check("... statuses only 0, 1, 2", bad_status == 0)
    check("the same command makes exactly the runs not committed, and no committed run again", not_once == 0)
    check("every final file: statuses, metrics, messages equal the uninterrupted sweep's bits", differ == 0)
    check("no .part or .lock left", not leftovers(tmp), str(leftovers(tmp)))
    return 0


def case_paths(exe, tmp):
    write(os.path.join(tmp, "tiny.nml"), TINY)
    os.symlink("nowhere/x.h5", os.path.join(tmp, "dangling.h5"))
    os.mkdir(os.path.join(tmp, "adir"))
    os.mkfifo(os.path.join(tmp, "fifo.h5"))
    for o, expect in (("/dev/null", "not a regular file"), ("adir", "it is a directory"),
                      ("fifo.h5", "not a regular file"), ("dangling.h5", "symbolic link"),
                      ("-", "does not apply to sweep")):
        r = run([exe, "sweep", "tiny.nml", "-o", o], tmp)
        check(f"-o {o}: exit 2, '{expect}'", r.returncode == 2 and expect in r.stderr and "Backtrace" not in r.stderr,
              f"rc {r.returncode}: {r.stderr}")
    check("the dangling link is still a link", os.path.islink(os.path.join(tmp, "dangling.h5")))
    check("the FIFO is still a FIFO", stat.S_ISFIFO(os.lstat(os.path.join(tmp, "fifo.h5")).st_mode))
    check("nothing created (no '-', no .part, no .lock, directory empty)",
          not os.path.exists(os.path.join(tmp, "-")) and not leftovers(tmp) and not os.listdir(os.path.join(tmp, "adir")),
          str(os.listdir(tmp)))
    return 0


def case_fingerprint(exe, tmp):
    write(os.path.join(tmp, "t.nml"), TABLE)
    write(os.path.join(tmp, "tab.txt"), "0.0 -5.0\n0.5 -5.0\n")
    r = run([exe, "sweep", "t.nml", "-o", "sw.h5"], tmp)
    check("sweep with a table file exits 0", r.returncode == 0, r.stderr)
    with h5py.File(os.path.join(tmp, "sw.h5"), "r+") as f:
        s = f["runs/status"][:]
        s[2:] = 0                                   # as if stopped after 2 runs
        f["runs/status"][...] = s
        fp = f.attrs["fingerprint"]
    check("the file's fingerprint names the deck, the table file, overrides and version",
          all(k in fp for k in ("deck ", "file ", "tab.txt", "overrides", "version ")), fp)
    write(os.path.join(tmp, "tab.txt"), "0.0 50.0\n0.5 50.0\n")
    r = run([exe, "sweep", "t.nml", "-o", "sw.h5"], tmp)
    check("table file edited: exit 2 'holds another sweep' naming the table file",
          r.returncode == 2 and "holds another sweep" in r.stderr and "tab.txt" in r.stderr, r.stderr)
    write(os.path.join(tmp, "tab.txt"), "0.0 -5.0\n0.5 -5.0\n")
    write(os.path.join(tmp, "t.nml"), "! a comment that changes nothing\n" +
          TABLE.replace("integrator = 'rk4' /", "integrator   =   'rk4'   /  ! same") + "\n\n")
    r = run([exe, "sweep", "t.nml", "-o", "sw.h5"], tmp)
    check("a comment and blanks added to the deck: the sweep resumes (exit 0, 2 runs made)",
          r.returncode == 0 and "sweep: 2 run(s) made" in r.stdout, r.stdout + r.stderr)
    write(os.path.join(tmp, "t.nml"), TABLE.replace("damping = 0.5", "damping = 0.6"))
    r = run([exe, "sweep", "t.nml", "-o", "sw.h5"], tmp)
    check("a deck value changed: exit 2 'holds another sweep (its deck differs ...)'",
          r.returncode == 2 and "its deck differs from t.nml" in r.stderr, r.stderr)
    return 0


def case_status(exe, tmp):
    write(os.path.join(tmp, "f.nml"), FAILING)
    run([exe, "sweep", "f.nml", "-o", "ref.h5"], tmp)
    run([exe, "sweep", "f.nml", "-o", "sw.h5"], tmp)
    with h5py.File(os.path.join(tmp, "sw.h5"), "r+") as f:
        s = f["runs/status"][:]
        s[10:15] = -1
        s[15:] = 7
        f["runs/status"][...] = s
    r = run([exe, "sweep", "f.nml", "-o", "sw.h5"], tmp)
    check("invalid statuses: exit 1 (the failing runs), 10 runs made again, the invalid values named",
          r.returncode == 1 and "sweep: 10 run(s) made" in r.stdout and "invalid status (-1" in r.stderr,
          r.stdout + r.stderr)
    ok, which = same(content(os.path.join(tmp, "ref.h5")), content(os.path.join(tmp, "sw.h5")))
    check("... the file equals the uninterrupted sweep's bits", ok, which)
    with h5py.File(os.path.join(tmp, "sw.h5"), "r") as f:
        meaning = f["runs/status"].attrs.get("meaning", "")
    check("/runs/status says what its values mean", meaning == "0 pending, 1 ok, 2 failed", repr(meaning))
    return 0


def case_signals(exe, tmp):
    deck = GHM + ("&sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645, count = 12 /\n"
                  "&sweep parameter = 'mesh.settle_cycles', values = 100 /\n"
                  "&sweep parameter = 'mesh.measure_cycles', values = 300 /\n")
    write(os.path.join(tmp, "s.nml"), deck)
    r = run([exe, "sweep", "s.nml", "-o", "ref.h5"], tmp)
    check("reference sweep exits 0", r.returncode == 0, r.stderr)
    ref = content(os.path.join(tmp, "ref.h5"))
    for sig, code in ((signal.SIGINT, 130), (signal.SIGTERM, 143)):
        name = signal.Signals(sig).name
        p = subprocess.Popen([exe, "sweep", "s.nml", "-o", f"{name}.h5", "--progress", "0"], cwd=tmp,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        lines = []
        for line in p.stderr:
            lines.append(line)
            if re.match(r"sweep: [2-9]/12 runs done", line):
                p.send_signal(sig)
                break
        rest = p.stderr.read()
        p.wait(timeout=TIMEOUT)
        err = "".join(lines) + rest
        check(f"{name}: exit {code}", p.returncode == code, f"rc {p.returncode}: {err}")
        m = re.search(rf"sweep interrupted by {name}: (\d+) of 12 run\(s\) recorded in {name}.h5 .*the same "
                      r"command resumes the sweep", err)
        check(f"{name}: says how many runs are recorded and that the same command resumes", m is not None, err)
        with h5py.File(os.path.join(tmp, f"{name}.h5"), "r") as f:
            k = int(np.count_nonzero(f["runs/status"][:]))
        check(f"{name}: the file holds the runs it says", m is not None and int(m.group(1)) == k, f"{k}")
        r = run([exe, "sweep", "s.nml", "-o", f"{name}.h5"], tmp)
        check(f"{name}: the same command completes the sweep, equal to an uninterrupted one",
              r.returncode == 0 and f"sweep: {12 - k} run(s) made" in r.stdout and
              same(ref, content(os.path.join(tmp, f"{name}.h5")))[0], r.stdout + r.stderr)
    mpirun = shutil.which("mpirun")
    if not mpirun:
        print("(no mpirun: the MPI part is not run)")
        return 0
    # under MPI: SIGTERM to every rank, as a batch system's cancel sends it
    p = subprocess.Popen([mpirun, "--allow-run-as-root", "--oversubscribe", "-np", "2", exe, "sweep", "s.nml", "-o",
                          "mpi.h5", "--progress", "0"], cwd=tmp, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         text=True)
    lines = []
    for line in p.stderr:
        lines.append(line)
        if "built without MPI" in line:
            p.wait()
            print("(trainsim built without MPI: the MPI part is not run)")
            return 0
        if re.match(r"sweep: [2-9]/12 runs done", line):
            ranks = subprocess.run(["pgrep", "-P", str(p.pid)], capture_output=True, text=True).stdout.split()
            for r in ranks:
                os.kill(int(r), signal.SIGTERM)
            break
    err = "".join(lines) + p.stderr.read()
    p.wait(timeout=TIMEOUT)
    check("2 MPI ranks, SIGTERM to both: mpirun exits 143, rank 0 says how many runs are recorded",
          p.returncode == 143 and "sweep interrupted by SIGTERM" in err, f"rc {p.returncode}: {err[-600:]}")
    r = run([mpirun, "--allow-run-as-root", "--oversubscribe", "-np", "2", exe, "sweep", "s.nml", "-o", "mpi.h5"], tmp)
    check("... the same command completes it, equal to an uninterrupted sweep",
          r.returncode == 0 and same(ref, content(os.path.join(tmp, "mpi.h5")))[0], r.stdout + r.stderr)
    # Ctrl-C in a terminal: SIGINT to mpirun's process group only (the ranks have groups
    # of their own); mpirun sends the ranks SIGCONT, SIGTERM a second later, SIGKILL a
    # second after that, and exits 1 whatever they do. Runs long enough (about 0.5 s
    # each) that the sweep is still going when the SIGTERM comes.
    write(os.path.join(tmp, "long.nml"), deck.replace("values = 300", "values = 6000"))
    p = subprocess.Popen([mpirun, "--allow-run-as-root", "--oversubscribe", "-np", "2", exe, "sweep", "long.nml",
                          "-o", "ctrlc.h5", "--progress", "0"], cwd=tmp, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    lines = []
    for line in p.stderr:
        lines.append(line)
        if re.match(r"sweep: [1-4]/12 runs done", line):
            os.killpg(p.pid, signal.SIGINT)
            break
    err = "".join(lines) + p.stderr.read()
    p.wait(timeout=TIMEOUT)
    m = re.search(r"sweep interrupted by SIGTERM: (\d+) of 12 run\(s\) recorded in ctrlc.h5 .*the same "
                  r"command resumes the sweep", err)
    with h5py.File(os.path.join(tmp, "ctrlc.h5"), "r") as f:
        k = int(np.count_nonzero(f["runs/status"][:]))
    check("Ctrl-C to mpirun: rank 0 says how many runs are recorded (mpirun's own status: 1), and the file "
          "holds them", p.returncode == 1 and m is not None and int(m.group(1)) == k and k < 12,
          f"rc {p.returncode}, {k} runs in the file: {err[-600:]}")
    r = run([mpirun, "--allow-run-as-root", "--oversubscribe", "-np", "2", exe, "sweep", "long.nml", "-o", "ctrlc.h5"],
            tmp)
    with h5py.File(os.path.join(tmp, "ctrlc.h5"), "r") as f:
        ok = bool(np.all(f["runs/status"][:] == 1))
    check("... the same command completes it", r.returncode == 0 and f"sweep: {12 - k} run(s) made" in r.stdout
          and ok, r.stdout + r.stderr)
    return 0


def case_export(exe, tmp):
    write(os.path.join(tmp, "tiny.nml"), TINY)
    run([exe, "sweep", "tiny.nml", "-o", "sw.h5"], tmp)
    for a in (["--metrics"], ["--events"], ["--summary", "json"], ["--spectrum"], ["mesh.force"]):
        r = run([exe, "export", "sw.h5", *a], tmp)
        check(f"export SWEEP {' '.join(a)}: exit 2, 'a sweep file', names trainsim plot, no traceback",
              r.returncode == 2 and "is a sweep file" in r.stderr and "trainsim plot sw.h5 --metric" in r.stderr
              and "Traceback" not in r.stderr, f"rc {r.returncode}: {r.stderr}")
    with open(os.path.join(tmp, "damaged.h5"), "wb") as f:
        f.write(b"\x89HDF\r\n\x1a\n" + b"\0" * 200)
    r = run([exe, "export", "damaged.h5", "--metrics"], tmp)
    check("export of a damaged file: exit 2, no traceback", r.returncode == 2 and "Traceback" not in r.stderr,
          f"rc {r.returncode}: {r.stderr}")
    return 0


def case_diskfull(exe, tmp):
    if os.geteuid() != 0:
        print("skipped: mounting a tmpfs needs root")
        return 77
    mnt = os.path.join(tmp, "mnt")
    os.mkdir(mnt)
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=8k", "tmpfs", mnt], capture_output=True).returncode:
        print("skipped: cannot mount a tmpfs here")
        return 77
    try:
        write(os.path.join(tmp, "f.nml"), FAILING)
        r = run([exe, "sweep", "f.nml", "-o", "mnt/sw.h5"], tmp)
        check("onto an 8 KiB tmpfs: exit 2 'No space left on device'",
              r.returncode == 2 and "No space left on device" in r.stderr, f"rc {r.returncode}: {r.stderr}")
        check("... nothing left on the disk (no .part, no .lock)", not os.listdir(mnt), str(os.listdir(mnt)))
    finally:
        subprocess.run(["umount", mnt])
    r = run([exe, "sweep", "f.nml", "-o", "ref.h5"], tmp)
    ref = content(os.path.join(tmp, "ref.h5"))
    size = os.path.getsize(os.path.join(tmp, "ref.h5"))
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size // 1024 + 64}k", "tmpfs", mnt], check=True)
    try:
        p = subprocess.Popen([exe, "sweep", "f.nml", "-o", "mnt/sw.h5", "--progress", "0"], cwd=tmp,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        while not os.path.exists(os.path.join(mnt, "sw.h5")) and p.poll() is None:
            time.sleep(0.002)
        subprocess.run(["dd", "if=/dev/zero", f"of={mnt}/fill", "bs=4k"], capture_output=True)
        err = p.communicate(timeout=TIMEOUT)[1]
        check("the disk filling while runs are recorded: exit 2 with a message, no crash",
              p.returncode == 2 and "No space left on device" in err, f"rc {p.returncode}: {err[-300:]}")
        os.remove(os.path.join(mnt, "fill"))
        r = run([exe, "sweep", "f.nml", "-o", "mnt/sw.h5"], tmp)
        check("space freed, the same command completes the sweep (exit 1: the failing runs)", r.returncode == 1,
              r.stderr)
        ok, which = same(ref, content(os.path.join(mnt, "sw.h5")))
        check("... equal to an uninterrupted sweep's bits, every failed run with its own message", ok, which)
    finally:
        subprocess.run(["umount", mnt])
    return 0


def main():
    exe, case = os.path.abspath(sys.argv[1]), sys.argv[2]
    fn = globals()["case_" + case]
    with tempfile.TemporaryDirectory() as tmp:
        rc = fn(exe, tmp)
    if rc == 77:
        return 77
    print(f"{len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
