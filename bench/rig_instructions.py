#!/usr/bin/python3
"""Instructions per step of the Table 5.5 rig: callgrind's total of a whole
`trainsim run RIG --no-output` at t_end 0.4 s minus that at 0.2 s, over the
25 000 steps between (events included; deterministic). The rig decks are the
ones of bench_rk4_throughput (shaft - ideal or backlash gear pair - shaft,
dt = 8e-6 s, node 1 held at 80 rad/s).

    /usr/bin/python3 bench/rig_instructions.py TRAINSIM [--keep DIR] [ideal-off backlash-off ideal-on backlash-on]

--keep DIR: the decks and callgrind's outputs go to DIR (rig_CASE_TEND.nml,
cg.CASE.TEND) and stay, for `callgrind_annotate` (per-step self costs: divide
the 0.4 s run's by 50 000 steps).
"""
import subprocess, sys, os, re, tempfile
args = sys.argv[1:]
keep = None
if '--keep' in args:
    k = args.index('--keep')
    keep = args[k + 1]
    del args[k:k + 2]
exe = args[0]
cases = args[1:] or ['ideal-off', 'backlash-off', 'ideal-on', 'backlash-on']
def deck(t_end, track, backlash):
    s = ("&run title = 'bench: Table 5.5 rig', t_end = %s, dt = 8.0e-6, integrator = 'rk4', track_energy = %s /\n"
         % (t_end, '.true.' if track else '.false.'))
    s += "".join("&node id = 'n%d', type = 'inertia', inertia = %s /\n" % (i, j) for i, j in
                 [(1, '100.0'), (2, '0.987'), (3, '0.987'), (4, '100.0')])
    s += "&element id = 'e1', type = 'shaft', stiffness = 32000.0 /\n"
    if backlash:
        s += ("&element id = 'e2', type = 'spur_gear', stiffness = 234500.0, rb_driver = 3.7588, rb_driven = 3.7588, "
              "teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005 /\n")
    else:
        s += "&element id = 'e2', type = 'ideal_gear', stiffness = 234500.0, rb_driver = 3.7588, rb_driven = 3.7588 /\n"
    s += ("&element id = 'e3', type = 'shaft', stiffness = 32000.0 /\n&initial node = 'all', speed = 80.0 /\n"
          "&initial node = 'n1', angle = -0.187847 /\n&initial node = 'n2', angle = -0.212810 /\n"
          "&initial node = 'n3', angle = -0.214283 /\n&initial node = 'n4', angle = -0.239246 /\n"
          "&load node = 'n1', quantity = 'speed', kind = 'constant', value = 80.0 /\n"
          "&load node = 'n4', kind = 'constant', value = -798.8 /\n")
    return s
d = keep or tempfile.mkdtemp(prefix='ipstep')
os.makedirs(d, exist_ok=True)
for c in cases:
    bl = c.startswith('backlash'); tr = c.endswith('-on')
    tot = []
    for te in ('0.2', '0.4'):
        f = os.path.join(d, 'rig_%s_%s.nml' % (c, te))
        open(f, 'w').write(deck(te, tr, bl))
        out = os.path.join(d, 'cg.%s.%s' % (c, te))
        subprocess.run(['valgrind', '--tool=callgrind', '--callgrind-out-file=' + out, exe, 'run', f, '--no-output'],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        txt = open(out).read()
        tot.append(int(re.search(r'^summary:\s+(\d+)', txt, re.M).group(1)))
    print('%-14s %8.1f instr/step' % (c, (tot[1] - tot[0]) / 25000.0), flush=True)
