#!/usr/bin/python3
"""trainsim sweep end to end. One case per CTest entry:

    /usr/bin/python3 tests/cli/check_sweep.py <trainsim> <case>

cases:
  mpi_matches_serial  mpirun -np 2, 3 and 4 give metrics bit-identical to the serial sweep, and
                      every rank made runs (rank 0 answers each worker's first request with a
                      run, then takes one of its own before it answers another request: D-110,
                      D-137, so this holds whatever the timing) (exit 77 = skipped when
                      mpirun is missing or trainsim was built without MPI)
  resume_after_kill   kill -9 part-way, then the same command: every run present exactly
                      once (the runs done before the kill are not made again, the others
                      are made once), and the metrics equal an uninterrupted sweep's bits
  continuation_resume a continuation sweep (up and down branches) killed with kill -9 in its
                      up branch, re-run and killed again in its down branch, re-run to the
                      end: every run made exactly once, metrics bit-identical to an
                      uninterrupted continuation sweep; the same from the first kill resumed
                      on 2 MPI ranks (when mpirun and an MPI build are there)
  failed_run          a run that blows up is recorded as failed with its message, the others
                      complete, exit status 1
  speed_range         each run's node speed range in the sweep file (/nodes/speed_min, speed_max)
                      equals the extremes of /nodes/omega in a `trainsim run` history of the same
                      run, to the bit (a sweep run's sink reads the speeds only: D-34)
  cli                 bad &sweep groups, bad sweep values and misuse fail with exit 2 and a
                      message naming file:line, group and value; run ignores &sweep groups
"""

import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile

import h5py
import numpy as np

TIMEOUT = 600

GHM = """&run  title = 'GHM rig, mesh-frequency sweep (test)'
      t_end = {t_end}, dt = 8.0e-6, integrator = 'rk4', output_interval = 8.0e-6 /
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
&initial node = 'n1', angle = -0.187847 /
&initial node = 'n2', angle = -0.212810 /
&initial node = 'n3', angle = -0.214283 /
&initial node = 'n4', angle = -0.239246 /
"""

# Three disks (Table 5.1): RK4 is stable for dt < 1.66e-2 s; 0.03 s blows up.
BLOWUP = """&run t_end = 3.0, dt = 1.0e-3 /
&node id = 'a', type = 'inertia', inertia = 5.0 /
&node id = 'b', type = 'inertia', inertia = 11.0 /
&element id = 's1', type = 'shaft', stiffness = 1.0e5 /
&initial node = 'a', angle = 0.1 /
&sweep parameter = 'run.dt', values = 1e-3, 0.03, 2e-3 /
"""

METRIC_GROUPS = ("elements", "nodes")

failures = []


def check(what, cond, detail=""):
    print(("ok   " if cond else "FAIL ") + what + (("  [" + detail + "]") if detail and not cond else ""))
    if not cond:
        failures.append(what)


def run(cmd, cwd, **kw):
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT, **kw)


def metrics(path):
    """Every metric dataset of a sweep file, by name."""
    out = {}
    with h5py.File(path, "r") as f:
        for g in METRIC_GROUPS:
            for k in f[g]:
                if k in ("ids", "types"):
                    continue
                out[g + "/" + k] = f[g][k][:]
        out["parameters/values"] = f["parameters/values"][:]
        out["runs/status"] = f["runs/status"][:]
    return out


def strings_of(f):
    """(name, kind) of every string attribute and dataset of an open file."""
    out = []

    def kind(dtype):
        info = h5py.check_string_dtype(dtype)
        if info is None:
            return None
        return ("vlen-" if info.length is None else "fixed-") + ("utf8" if info.encoding == "utf-8" else "ascii")

    def visit(name, obj):
        for a in obj.attrs:
            k = kind(obj.attrs.get_id(a).dtype)
            if k:
                out.append((name + "@" + a, k))
        if isinstance(obj, h5py.Dataset):
            k = kind(obj.dtype)
            if k:
                out.append((name, k))

    visit("/", f)
    f.visititems(visit)
    return out


def same_bits(a, b):
    if a.keys() != b.keys():
        return False, "different datasets"
    for k in a:
        x, y = a[k], b[k]
        if x.dtype.kind == "f":
            x, y = x.view(np.uint64), y.view(np.uint64)
        if not np.array_equal(x, y):
            return False, k
    return True, ""


def case_mpi_matches_serial(exe, tmp):
    mpirun = shutil.which("mpirun")
    if not mpirun:
        print("skipped: no mpirun")
        return 77
    deck = os.path.join(tmp, "ghm.nml")
    with open(deck, "w") as f:
        f.write(GHM.format(t_end=0.03) + "&sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645, count = 14 /\n")
    r = run([exe, "sweep", "ghm.nml", "-o", "serial.h5"], tmp)
    check("serial sweep exits 0", r.returncode == 0, r.stderr)
    for n in (2, 3, 4):
        out = f"mpi{n}.h5"
        r = run([mpirun, "--allow-run-as-root", "--oversubscribe", "-np", str(n), exe, "sweep", "ghm.nml", "-o", out],
                tmp)
        if "built without MPI" in r.stderr:
            print("skipped: trainsim built without MPI")
            return 77
        check(f"mpirun -np {n} sweep exits 0", r.returncode == 0, r.stderr)
        check(f"... and says it ran on {n} ranks", f"on {n} rank(s)" in r.stderr, r.stderr)
        a, b = metrics(os.path.join(tmp, "serial.h5")), metrics(os.path.join(tmp, out))
        ok, which = same_bits(a, b)
        check("... every metric of every run bit-identical to the serial sweep", ok, which)
        with h5py.File(os.path.join(tmp, out), "r") as f:
            ranks = set(f["runs/rank"][:].tolist())
        check(f"... every one of the {n} ranks made runs (the dynamic hand-out reached each)",
              ranks == set(range(n)), str(ranks))
    with open(os.path.join(tmp, "bad.nml"), "w") as f:
        f.write(GHM.format(t_end=0.01) + "&sweep parameter = 'mesh.half_backlash', values = 0.005, 0.004, -1.0 /\n")
    for n in ("2", "3"):
        r = run([mpirun, "--allow-run-as-root", "--oversubscribe", "-np", n, exe, "sweep", "bad.nml", "-o", "bad.h5"],
                tmp)
        check(f"a run that does not build, on {n} ranks (validated by rank {2 % int(n)}): exit 2, rank 0 says which",
              r.returncode == 2 and "(run 3: mesh.half_backlash = -1)" in r.stderr, f"rc {r.returncode}: {r.stderr}")
        check("... no sweep file", not os.path.exists(os.path.join(tmp, "bad.h5")))
    return 0


def kill_after(cmd, cwd, n, at):
    """Start `cmd` (a sweep with --progress 0), kill -9 it once `at` runs are done."""
    p = subprocess.Popen(cmd, cwd=cwd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                         start_new_session=True)
    seen = 0
    for line in p.stderr:
        m = re.match(r"sweep: (\d+)/%d runs done" % n, line)
        if m:
            seen = int(m.group(1))
            if seen >= at:
                os.killpg(p.pid, signal.SIGKILL)
                break
    p.wait(timeout=TIMEOUT)
    return p.returncode, seen


def case_resume_after_kill(exe, tmp):
    n = 16
    deck = os.path.join(tmp, "ghm.nml")
    with open(deck, "w") as f:
        f.write(GHM.format(t_end=0.12) + f"&sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645, count = {n} /\n")
    r = run([exe, "sweep", "ghm.nml", "-o", "ref.h5"], tmp)
    check("uninterrupted reference sweep exits 0", r.returncode == 0, r.stderr)

    cmd = [exe, "sweep", "ghm.nml", "-o", "killed.h5", "--progress", "0"]
    rc, seen = kill_after(cmd, tmp, n, 4)
    check("the sweep was killed part-way (by SIGKILL)", rc == -signal.SIGKILL and 4 <= seen < n,
          f"rc {rc}, seen {seen}")
    path = os.path.join(tmp, "killed.h5")
    with h5py.File(path, "r") as f:
        status = f["runs/status"][:]
        wall_before = f["runs/wall_time"][:]
    k = int(np.count_nonzero(status))
    check("the killed file opens; runs done before the kill are recorded", seen <= k < n, f"k = {k}, seen {seen}")
    check("... each as complete (status 1) or pending (0), nothing else", set(status.tolist()) <= {0, 1})

    r = run([exe, "sweep", "ghm.nml", "-o", "killed.h5"], tmp)
    check("the same command again exits 0", r.returncode == 0, r.stderr)
    check("it resumes: k done, n - k to run",
          f"{k} of {n} runs already done, {n - k} to run" in r.stderr, r.stderr)
    check("it made exactly the n - k missing runs", f"sweep: {n - k} run(s) made, {n} of {n} ok" in r.stdout, r.stdout)
    with h5py.File(path, "r") as f:
        status2 = f["runs/status"][:]
        wall_after = f["runs/wall_time"][:]
    done = status != 0
    check("every run present exactly once: all n complete", np.all(status2 == 1))
    check("runs done before the kill were not made again (their wall times unchanged to the bit)",
          np.array_equal(wall_before[done].view(np.uint64), wall_after[done].view(np.uint64)))
    ok, which = same_bits(metrics(os.path.join(tmp, "ref.h5")), metrics(path))
    check("metrics bit-identical to the uninterrupted sweep", ok, which)

    r = run([exe, "sweep", "ghm.nml", "-o", "killed.h5", "--resume"], tmp)
    check("--resume of a complete sweep makes no run", r.returncode == 0 and "sweep: 0 run(s) made" in r.stdout,
          r.stdout + r.stderr)
    r = run([exe, "sweep", "ghm.nml", "-o", "absent.h5", "--resume"], tmp)
    check("--resume without a file: exit 2, says so", r.returncode == 2 and "nothing to resume" in r.stderr, r.stderr)
    with open(deck, "a") as f:
        f.write("! changed\n&sweep parameter = 'mesh.half_backlash', values = 0.004, 0.005 /\n")
    r = run([exe, "sweep", "ghm.nml", "-o", "killed.h5"], tmp)
    check("a changed deck does not resume into the old file: exit 2",
          r.returncode == 2 and "holds another sweep" in r.stderr, r.stderr)
    return 0


def file_state(path):
    with h5py.File(path, "r") as f:
        return f["runs/status"][:], f["runs/wall_time"][:], f["runs/branch"][:]


def case_continuation_resume(exe, tmp):
    n_branch = 8
    n = 2 * n_branch
    deck = os.path.join(tmp, "cont.nml")
    with open(deck, "w") as f:
        f.write(GHM.format(t_end=0.02).replace("output_interval = 8.0e-6 /", "output_interval = 8.0e-6,\n"
                                                "      initial_state = 'preload' /") +
                f"&sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645, count = {n_branch}, "
                "continuation = 'both' /\n"
                "&sweep parameter = 'mesh.settle_cycles', values = 100 /\n"
                "&sweep parameter = 'mesh.measure_cycles', values = 200 /\n")
    r = run([exe, "sweep", "cont.nml", "-o", "ref.h5"], tmp)
    check("uninterrupted continuation sweep exits 0", r.returncode == 0, r.stderr)
    ref = metrics(os.path.join(tmp, "ref.h5"))
    _, _, branch = file_state(os.path.join(tmp, "ref.h5"))
    up, down = branch == 1, branch == 2
    check("it has an up and a down branch", up.sum() == n_branch and down.sum() == n_branch, str(branch))

    path = os.path.join(tmp, "k.h5")
    cmd = [exe, "sweep", "cont.nml", "-o", "k.h5", "--progress", "0"]
    # (kill after 2 runs of a branch of 8: room for 5 more runs of lag on a busy machine)
    rc, seen = kill_after(cmd, tmp, n, 2)
    check("first kill -9 part-way", rc == -signal.SIGKILL and seen >= 2, f"rc {rc}, seen {seen}")
    s1, w1, _ = file_state(path)
    k1 = int(np.count_nonzero(s1))
    check("... in the up branch (down not started)", 2 <= k1 < n_branch and not s1[down].any(), str(s1))
    shutil.copy(path, os.path.join(tmp, "k_mpi.h5"))

    rc, seen = kill_after(cmd, tmp, n, n_branch + 2)
    check("resumed, then killed -9 again part-way", rc == -signal.SIGKILL, f"rc {rc}, seen {seen}")
    s2, w2, _ = file_state(path)
    k2 = int(np.count_nonzero(s2))
    check("... in the down branch (up complete)", s2[up].all() and 2 <= s2[down].sum() < n_branch, str(s2))
    check("... the runs of the first part kept (wall times unchanged to the bit)",
          np.array_equal(w1[s1 != 0].view(np.uint64), w2[s1 != 0].view(np.uint64)))

    r = run([exe, "sweep", "cont.nml", "-o", "k.h5"], tmp)
    check("the same command again exits 0", r.returncode == 0, r.stderr)
    check("it made exactly the missing runs", f"sweep: {n - k2} run(s) made, {n} of {n} ok" in r.stdout, r.stdout)
    s3, w3, _ = file_state(path)
    check("every run present exactly once: all complete", np.all(s3 == 1), str(s3))
    check("no run made twice (wall times of runs done before the kill unchanged)",
          np.array_equal(w2[s2 != 0].view(np.uint64), w3[s2 != 0].view(np.uint64)))
    ok, which = same_bits(ref, metrics(path))
    check("every metric (and end state) bit-identical to the uninterrupted continuation sweep", ok, which)

    mpirun = shutil.which("mpirun")
    if mpirun:
        r = run([mpirun, "--allow-run-as-root", "--oversubscribe", "-np", "2", exe, "sweep", "cont.nml",
                 "-o", "k_mpi.h5"], tmp)
        if "built without MPI" in r.stderr:
            print("(MPI part skipped: trainsim built without MPI)")
        else:
            check("resumed on 2 MPI ranks: exit 0", r.returncode == 0, r.stderr)
            ok, which = same_bits(ref, metrics(os.path.join(tmp, "k_mpi.h5")))
            check("... bit-identical to the uninterrupted serial continuation sweep", ok, which)
            with h5py.File(os.path.join(tmp, "k_mpi.h5"), "r") as f:
                ranks = f["runs/rank"][:]
            check("... both ranks made runs", set(ranks[s1 == 0].tolist()) == {0, 1}, str(ranks))
    return 0


def case_failed_run(exe, tmp):
    with open(os.path.join(tmp, "blowup.nml"), "w") as f:
        f.write(BLOWUP)
    r = run([exe, "sweep", "blowup.nml", "-o", "b.h5"], tmp)
    check("a sweep with a failed run exits 1", r.returncode == 1, f"rc {r.returncode}: {r.stderr}")
    check("the summary counts it", "2 of 3 ok, 1 failed" in r.stdout, r.stdout)
    with h5py.File(os.path.join(tmp, "b.h5"), "r") as f:
        status = f["runs/status"][:].tolist()
        msg = f["runs/message"].asstr()[:].tolist()
        p2p = f["elements/p2p_range"][:, 0]
        impacts = f["elements/impacts"][:, 0]
    check("run 2 (dt = 0.03) failed, runs 1 and 3 completed", status == [1, 2, 1], str(status))
    check("its message says why", "blew up" in msg[1], msg[1])
    check("the completed runs have their metrics, the failed one NaN / -1",
          np.isfinite(p2p[[0, 2]]).all() and np.isnan(p2p[1]) and impacts[1] == -1, f"{p2p} {impacts}")
    return 0


def case_speed_range(exe, tmp):
    values = (400.0, 520.0)
    with open(os.path.join(tmp, "ghm.nml"), "w") as f:
        f.write(GHM.format(t_end=0.01) + "&sweep parameter = 'mesh.mesh_frequency', values = "
                + ", ".join(repr(v) for v in values) + " /\n")
    r = run([exe, "sweep", "ghm.nml", "-o", "sw.h5"], tmp)
    check("sweep of 2 mesh frequencies: exit 0", r.returncode == 0, r.stderr)
    with h5py.File(os.path.join(tmp, "sw.h5"), "r") as f:
        wmin, wmax = f["nodes/speed_min"][:], f["nodes/speed_max"][:]
        par = f["parameters/values"][:, 0]
    for i, v in enumerate(values):
        k = int(np.argmin(np.abs(par - v)))
        r = run([exe, "run", "ghm.nml", "--set", f"mesh.mesh_frequency={v!r}", "-o", f"r{i}.h5"], tmp)
        check(f"run at {v} teeth/s: exit 0", r.returncode == 0, r.stderr)
        with h5py.File(os.path.join(tmp, f"r{i}.h5"), "r") as f:
            om = f["nodes/omega"][:]
        check(f"{v} teeth/s: the sweep's speed_max is the history's maximum speed of every node, to the bit",
              np.array_equal(wmax[k].view(np.uint64), om.max(axis=0).view(np.uint64)), f"{wmax[k]} {om.max(axis=0)}")
        check(f"{v} teeth/s: ... and speed_min its minimum", np.array_equal(wmin[k].view(np.uint64),
              om.min(axis=0).view(np.uint64)), f"{wmin[k]} {om.min(axis=0)}")
        check(f"{v} teeth/s: the speeds vary (the range is not a constant)", bool(np.all(om.max(axis=0)[1:] >
                                                                                      om.min(axis=0)[1:])))
    return 0


def case_cli(exe, tmp):
    base = GHM.format(t_end=0.01)
    cases = [
        ("&sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645 /\n",
         ["ghm.nml:19:", "&sweep #1", "missing required key 'count'"]),
        ("&sweep parameter = 'mesh.mesh_frequency', values = 400, step = 3 /\n",
         ["ghm.nml:19:", "unknown key 'step'", "valid keys are"]),
        ("&sweep parameter = 'mesh.half_backlash', values = 0.005, -1.0 /\n",
         ["ghm.nml:19: &sweep #1 (run 2: mesh.half_backlash = -1)", "half_backlash must be >= 0"]),
        ("&sweep parameter = 'mesh.stiffness', values = 1e5, 2e5 /\n"
         "&sweep parameter = 'run.t_end', values = 0.01, 0.02, 0.03, mode = 'zip' /\n",
         ["ghm.nml:20:", "mode = 'zip'", "which has 2 values; this one has 3"]),
        ("&sweep parameter = 'nope.stiffness', values = 1 /\n",
         ["ghm.nml:19: &sweep #1", "no node or element with id 'nope'"]),
        ("&sweep parameter = 'mesh.mesh_frequency', from = -1, to = 10, count = 3, scale = 'log' /\n",
         ["ghm.nml:19:", "scale = 'log' needs from > 0"]),
    ]
    for i, (extra, expect) in enumerate(cases):
        with open(os.path.join(tmp, "ghm.nml"), "w") as f:
            f.write(base + extra)
        r = run([exe, "sweep", "ghm.nml", "-o", f"c{i}.h5"], tmp)
        ok = r.returncode == 2 and all(e in r.stderr for e in expect) and "Backtrace" not in r.stderr
        check(f"bad sweep {i + 1}: exit 2 naming " + " | ".join(expect), ok, f"rc {r.returncode}: {r.stderr}")
        check(f"bad sweep {i + 1}: no sweep file left", not os.path.exists(os.path.join(tmp, f"c{i}.h5")))
    with open(os.path.join(tmp, "ghm.nml"), "w") as f:
        f.write(base + "&sweep parameter = 'mesh.mesh_frequency', values = 400, 500 /\n")
    r = run([exe, "sweep", "ghm.nml", "--set", "mesh.mesh_frequency=300"], tmp)
    check("--set of a swept parameter: exit 2", r.returncode == 2 and "is swept by ghm.nml:19" in r.stderr, r.stderr)
    r = run([exe, "sweep", "ghm.nml", "--set", "mesh.half_backlash=abc"], tmp)
    check("--set with a bad value: exit 2 naming the argument",
          r.returncode == 2 and "--set mesh.half_backlash=abc: error:" in r.stderr, r.stderr)
    r = run([exe, "sweep", "ghm.nml", "--set", "mesh.half_backlash=0.004"], tmp)
    check("default sweep file DECK_sweep.h5, --set recorded in it", r.returncode == 0 and
          os.path.exists(os.path.join(tmp, "ghm_sweep.h5")), r.stderr)
    with h5py.File(os.path.join(tmp, "ghm_sweep.h5"), "r") as f:
        check("... overrides attribute (a str: variable-length UTF-8)",
              f.attrs["overrides"] == "--set mesh.half_backlash=0.004", repr(f.attrs["overrides"]))
        check("... deck text stored", "&sweep parameter" in f["deck_text"].asstr()[0])
        strings = strings_of(f)
        check("every string of the file is variable-length UTF-8 (no fixed-length byte strings)",
              all(kind == "vlen-utf8" for _, kind in strings), str([s for s in strings if s[1] != "vlen-utf8"]))
        check("... attributes read as str, datasets with .asstr()", len(strings) >= 12, str(len(strings)))
    r = run([exe, "run", "ghm.nml"], tmp)
    check("run of a sweep deck: exit 0, says it ignores the &sweep groups",
          r.returncode == 0 and "ignores them" in r.stderr, r.stderr)
    r = run([exe, "run", "ghm.nml", "--resume"], tmp)
    check("--resume with run: exit 2", r.returncode == 2 and "only applies to sweep" in r.stderr, r.stderr)
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
