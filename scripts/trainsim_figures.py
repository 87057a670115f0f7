#!/usr/bin/python3
"""What trainsim's figures share (trainsim plot, its sweep figures, trainsim diagram):

- the unit of a deck key, a sweep metric or a run quantity in the file's unit system
  (the root attribute `units`: `in-lbf-s` or `si`; docs/deck.md gives each key's unit);
- a display unit chosen for the magnitude: SI values get a prefix that brings them into
  [1, 1000) (a TE of 2e-5 m is drawn in µm, a force of 3e4 N in kN); inch-pound values
  stay in in, lbf and lbf·in (no prefixes are used with them);
- `describe_figure`: the axis labels, legend entries and line sizes of a drawn figure
  as JSON (the hidden option --describe FILE of the plot scripts; what the tests read).
"""
import json

import numpy as np

# the base units of each system (docs/output-format.md, "Units")
SYSTEMS = {
    "in-lbf-s": {"length": "in", "force": "lbf", "torque": "lbf*in", "inertia": "lbf*in*s^2", "energy": "lbf*in"},
    "si": {"length": "m", "force": "N", "torque": "N*m", "inertia": "kg*m^2", "energy": "J"},
}

# deck keys -> dimension (docs/deck.md); the words are replaced by the system's units
KEY_DIMENSION = {
    "t_start": "s", "t_end": "s", "dt": "s", "output_interval": "s", "settle_time": "s", "max_step": "s",
    "event_tol": "s", "rtol": "1", "atol_angle": "rad", "atol_speed": "rad/s", "atol_current": "A",
    "inertia": "inertia", "damping": "torque*s/rad", "torque_constant": "torque/A", "inductance": "H",
    "resistance": "ohm", "back_emf_constant": "V*s/rad",
    "rb_driver": "length", "rb_driven": "length", "teeth": "teeth", "teeth_driver": "teeth", "teeth_driven": "teeth",
    "contact_ratio": "1", "profile_contact_ratio": "1", "approach_angle": "rad", "half_backlash": "length",
    "backlash": "length", "face_width": "length", "diametral_pitch": "1/in", "module": "mm", "pressure_angle": "deg",
    "stiffness_per_width": "force/length^2", "two_pair_factor": "1", "base_helix_angle": "deg",
    "youngs_modulus": "force/length^2", "diameter": "length", "half_clearance": "length", "key_length": "length",
    "friction": "1", "phi": "rad", "load_radius": "length", "friction_angle": "rad", "friction_velocity": "rad/s",
    "clearance": "rad", "radius": "length", "restitution": "1", "gear_ratio": "1",
    "mesh_frequency": "teeth/s", "settle_cycles": "mesh cycles", "measure_cycles": "mesh cycles",
    "angle": "rad", "speed": "rad/s", "current": "A", "frequency": "Hz", "phase": "rad",
    "t_step": "s", "t0": "s", "t1": "s", "t_accel": "s", "t_cruise": "s", "t_decel": "s", "t_dwell": "s",
    "cycles": "1",
}
# keys whose dimension depends on the element: angular elements (displacement in rad)
ANGULAR_KEY_DIMENSION = {"stiffness": "torque/rad", "contact_damping": "torque*s/rad",
                         "min_approach_velocity": "rad/s", "initial_contact_velocity": "rad/s"}
LINEAR_KEY_DIMENSION = {"stiffness": "force/length", "contact_damping": "force*s/length",
                        "min_approach_velocity": "length/s", "initial_contact_velocity": "length/s"}
# element types whose displacement is a length along a line of action (the others: an angle)
LINEAR_TYPES = ("spur_gear", "helical_gear", "ideal_gear", "keyed_joint")

# sweep-file metrics (docs/sweeps.md) -> dimension, for an element of each kind
METRIC_DIMENSION = {
    "force_min": "force", "force_max": "force", "max_peak_force": "force",
    "torque_min": "torque", "torque_max": "torque",
    "disp_min": "displacement", "disp_max": "displacement", "displacement_min": "displacement",
    "displacement_max": "displacement", "p2p_range": "displacement", "p2p_mean": "displacement",
    "impacts": "count", "separations": "count", "zone_changes": "count", "p2p_swings": "count",
    "max_approach_velocity": "displacement/s", "time_out_of_contact": "s", "load_sharing": "1",
    "kv": "1", "static_force": "force", "static_te_mean": "displacement", "static_te_p2p": "displacement",
    "force_mean": "force", **{f"te_order_{k}": "displacement" for k in range(1, 5)},
    **{f"force_order_{k}": "force" for k in range(1, 5)}, "rattle_impacts": "1", "rattle_open": "1",
    "rattle_criterion": "1", "rattle_energy": "energy", "rattle_power": "energy/s",
    "speed_min": "rad/s", "speed_max": "rad/s", "end_speed": "rad/s", "start_speed": "rad/s", "end_angle": "rad",
    "wall_time": "s", "steps": "count", "rhs_evals": "count", "events": "count", "energy_residual": "1",
    "rank": "1", "branch": "1", "status": "1",
}
# words for the metrics and quantities on an axis
METRIC_WORDS = {
    "p2p_mean": "mean peak-to-peak displacement", "p2p_range": "peak-to-peak displacement range",
    "disp_min": "smallest displacement", "disp_max": "largest displacement",
    "force_min": "smallest force", "force_max": "largest force", "max_peak_force": "largest peak contact force",
    "torque_min": "smallest torque", "torque_max": "largest torque", "impacts": "impacts",
    "separations": "separations", "zone_changes": "mesh-zone changes", "p2p_swings": "peak-to-peak swings",
    "max_approach_velocity": "largest approach velocity", "time_out_of_contact": "time out of contact",
    "load_sharing": "load-sharing factor", "kv": "dynamic factor Kv", "static_force": "static mesh force",
    "static_te_mean": "mean loaded static displacement", "static_te_p2p": "peak-to-peak loaded static displacement",
    "speed_min": "lowest speed", "speed_max": "highest speed", "end_speed": "speed at the end",
    "start_speed": "speed at the start", "end_angle": "angle at the end", "wall_time": "wall time",
    "steps": "steps", "rhs_evals": "RHS evaluations", "events": "events", "energy_residual": "energy residual",
    "mesh_frequency": "mesh frequency", "half_backlash": "half backlash", "half_clearance": "half clearance",
    "rattle_criterion": "rattle criterion J alpha / T_drag", "rattle_energy": "impact energy per mesh cycle",
    "rattle_power": "impact power",
}
GEAR_TYPES = ("spur_gear", "helical_gear", "ideal_gear")


def system(units):
    return SYSTEMS.get(str(units), SYSTEMS["in-lbf-s"])


def resolve(dim, units):
    """A dimension written with the words length, force, torque, inertia, energy -> the
    unit of `units` ('in-lbf-s' or 'si'); 'count' and '1' -> '1'."""
    if dim in ("count", "1", ""):
        return "1"
    sysu = system(units)
    out = dim
    for word in ("inertia", "torque", "length", "force", "energy"):   # inertia before length
        out = out.replace(word, sysu[word])
    return out


def key_unit(key, units, element_type=None, quantity=None):
    """Unit of deck key `key` (of an element of `element_type`, of a load of `quantity`),
    or None when it is not known."""
    if key in ("value", "value0", "value1", "amplitude", "offset", "values"):
        return {"torque": resolve("torque", units), "speed": "rad/s", "voltage": "V"}.get(quantity or "")
    if key in ANGULAR_KEY_DIMENSION:
        if element_type is None:
            return None
        table = LINEAR_KEY_DIMENSION if element_type in LINEAR_TYPES else ANGULAR_KEY_DIMENSION
        if element_type == "shaft" and key == "stiffness":
            table = ANGULAR_KEY_DIMENSION
        return resolve(table[key], units)
    if key == "damping" and element_type is not None and element_type not in ("shaft", "damper"):
        return None
    dim = KEY_DIMENSION.get(key)
    return None if dim is None else resolve(dim, units)


def metric_unit(metric, units, element_type=None):
    """Unit of a sweep-file metric of an element of `element_type` (None: a node or run metric)."""
    dim = METRIC_DIMENSION.get(metric)
    if dim is None:
        return None
    linear = element_type in LINEAR_TYPES
    if dim == "force" and element_type is not None and not linear:
        dim = "torque"       # a shaft's or coupling's force is its torque
    dim = dim.replace("displacement", "length" if linear else "rad")
    return resolve(dim, units)


def pretty(unit):
    """lbf*in -> lbf·in, s^2 -> s², for labels."""
    return str(unit).replace("*", "·").replace("^2", "²").replace("^3", "³")


# SI units that take a prefix for the magnitude, and the prefixed units allowed (largest first)
_SCALED = {
    "m": [(1.0, "m"), (1e-3, "mm"), (1e-6, "µm"), (1e-9, "nm")],
    "m/s": [(1.0, "m/s"), (1e-3, "mm/s"), (1e-6, "µm/s")],
    "N": [(1e6, "MN"), (1e3, "kN"), (1.0, "N")],
    "N*m": [(1e6, "MN·m"), (1e3, "kN·m"), (1.0, "N·m"), (1e-3, "mN·m")],
    "J": [(1e6, "MJ"), (1e3, "kJ"), (1.0, "J"), (1e-3, "mJ")],
}


def display_unit(values, unit):
    """(factor, unit label) for drawing `values` of `unit`: for the SI units of length,
    line speed, force, torque and energy the prefix that puts the largest |value| in
    [1, 1000) (a TE of 2e-5 m in µm, a force of 3e4 N in kN; the smallest prefix below
    that); any other unit (in, lbf, lbf·in, rad, s, counts) as it is."""
    choices = _SCALED.get(str(unit))
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    top = float(np.max(np.abs(v))) if v.size else 0.0
    if not choices or top == 0.0:
        return 1.0, pretty(unit)
    for scale, name in choices:
        if top >= scale:
            return 1.0 / scale, name
    scale, name = choices[-1]
    return 1.0 / scale, name


def label(words, unit):
    """'words [unit]' ('[-]' for a dimensionless count or ratio)."""
    u = "-" if unit in ("1", "", None) else pretty(unit)
    return f"{words} [{u}]"


def describe_figure(fig, path):
    """Write the axes of `fig` as JSON to `path`: for each axis its title, x and y labels,
    legend entries, and each line's label and number of points (collections too)."""
    out = {"axes": []}
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            out["axes"].append({"kind": "colorbar", "ylabel": ax.get_ylabel(), "xlabel": ax.get_xlabel()})
            continue
        leg = ax.get_legend()
        lines = []
        for ln in ax.get_lines():
            x = np.asarray(ln.get_xdata())
            lines.append({"label": ln.get_label(), "points": int(x.size), "gid": ln.get_gid()})
        out["axes"].append({
            "kind": "axes", "title": ax.get_title(), "xlabel": ax.get_xlabel(), "ylabel": ax.get_ylabel(),
            "legend": [t.get_text() for t in leg.get_texts()] if leg else [],
            "lines": lines, "collections": len(ax.collections),
            "x_ticks_labelled": bool(ax.axison and ax.xaxis.get_visible()
                                     and any(t.get_visible() and t.get_text() for t in ax.get_xticklabels())),
            "y_ticks_labelled": bool(ax.axison and ax.yaxis.get_visible()
                                     and any(t.get_visible() and t.get_text() for t in ax.get_yticklabels())),
        })
    out["suptitle"] = fig._suptitle.get_text() if getattr(fig, "_suptitle", None) else ""
    with open(path, "w", encoding="utf-8") as f:
        json.dump(out, f, indent=1)
