#!/usr/bin/python3
"""The tracker deck's day (inputs/tracker_azimuth.nml): docs/tracker_azimuth.png.

Reads the history of a run of the day (bench/tracker_day.py writes it) and plots, against
the (compressed) time: the table's and the ring's angle against the target; the motor's
current with the current limit; the mesh forces of the worm stand-in and the two spur
stages; the sequence's hold (the brake command: on from each target_reached event to the
next target's time), with the wind torque. A second column zooms on three moves.

usage: /usr/bin/python3 docs/tracker_azimuth.py HISTORY.h5 [OUT.png]
       (default OUT: docs/tracker_azimuth.png)
"""
import os
import sys

import h5py
import numpy as np
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def column(ds, name):
    names = [n.decode() if isinstance(n, bytes) else n for n in ds.attrs['column_names']]
    return ds[:, names.index(name)]


def main():
    h5 = sys.argv[1]
    out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, 'docs', 'tracker_azimuth.png')
    targets = np.loadtxt(os.path.join(ROOT, 'inputs', 'tracker_targets.txt'))
    wind = np.loadtxt(os.path.join(ROOT, 'inputs', 'tracker_wind.txt'))
    with h5py.File(h5) as f:
        t = f['time'][:]
        table = column(f['nodes/theta'], 'table')
        ring = column(f['nodes/theta'], 'ring')
        states = f['states']
        current = column(states, 'motor.current') if 'column_names' in states.attrs else None
        force = {k: column(f['elements/force'], k) for k in ('worm_stage', 'stage2', 'stage3')}
        kinds = f['events/kind_name'][:]
        t_ev = f['events/time'][:][kinds == b'target_reached']
    # the target and the hold (brake command) at each sample
    slot = np.searchsorted(targets[:, 0], t, side='right') - 1
    target = np.where(slot >= 0, targets[np.maximum(slot, 0), 1], 0.0)
    reached = np.searchsorted(t_ev, t, side='right')            # events up to t
    slot_of_ev = np.searchsorted(targets[:, 0], t_ev, side='right') - 1
    first = 0 if abs(ring[0] - targets[0, 1]) < 5.0e-4 else -1   # at rest on the first target: reached at the start
    last_reached = np.where(reached > 0, slot_of_ev[np.maximum(reached - 1, 0)], first)
    hold = (last_reached >= slot) | (slot < 0)
    wind_t = np.interp(t, wind[:, 0], wind[:, 1])

    fig, ax = plt.subplots(4, 2, figsize=(13, 10), sharex='col')
    k0 = max(1, len(t_ev)//2 - 1)                               # three moves from the middle of the run
    k = np.searchsorted(t, [targets[k0, 0] - 0.1, targets[min(k0 + 3, len(targets) - 1), 0]])
    for c, sl in enumerate([slice(None), slice(k[0], k[1])]):
        a = ax[0, c]
        a.plot(t[sl], np.degrees(target[sl]), 'k--', lw=1, label='target')
        a.plot(t[sl], np.degrees(ring[sl]), lw=0.8, label='ring (sensor)')
        a.plot(t[sl], np.degrees(table[sl]), lw=0.8, label='table')
        a.set_ylabel('azimuth from the morning (deg)')
        a.legend(loc='upper left', fontsize=8)
        a = ax[1, c]
        if current is not None:
            a.plot(t[sl], current[sl], lw=0.6)
        a.axhline(30.0, color='r', lw=0.8, ls=':')
        a.axhline(-30.0, color='r', lw=0.8, ls=':', label='current limit')
        a.set_ylabel('motor current (A)')
        a.legend(loc='upper left', fontsize=8)
        a = ax[2, c]
        for name, fv in force.items():
            a.plot(t[sl], fv[sl]/1000.0, lw=0.6, label=name)
        a.set_ylabel('mesh force (kN)')
        a.legend(loc='upper left', fontsize=8)
        a = ax[3, c]
        a.fill_between(t[sl], 0, hold[sl].astype(float), step='post', alpha=0.4, label='hold (brake command)')
        a.set_ylabel('hold')
        a2 = a.twinx()
        a2.plot(t[sl], wind_t[sl], 'g', lw=0.8, label='wind torque')
        a2.set_ylabel('wind on the table (N m)')
        a.legend(loc='upper left', fontsize=8)
        a.set_xlabel('time (s; the day compressed 300x)')
    ax[0, 0].set_title(f'{t[-1]:.1f} s of the day (compressed 300x): {len(t_ev)} moves completed, '
                       f'{int(np.sum(targets[:, 0] <= t[-1]))} targets due')
    ax[0, 1].set_title('three moves')
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print(f'wrote {out}')


if __name__ == '__main__':
    main()
