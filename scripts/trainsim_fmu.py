#!/usr/bin/python3
"""Pack a train as an FMI 3.0 (or 2.0) co-simulation FMU (run by `trainsim fmu`; docs/fmu.md).

Reads the variables `trainsim fmu` listed (JSON), writes modelDescription.xml, and zips it
with the deck and its table files (resources/) and the binary that runs it
(binaries/x86_64-linux/ for FMI 3.0, binaries/linux64/ for 2.0: trainsim_fmu.so and
libtrainsim_c, from build/fmu or the installed <prefix>/lib/.../trainsim/fmu). Value
references as src/fmu/fmu_core.h reads them: 0 time (FMI 3.0); node k (0-based) angle
1 + 2k, speed 2 + 2k; input j 1000000 + j; parameter p 2000000 + p (Float64, Int32 or
String: as the deck writes the value); element e (0-based) displacement 3000000 + 3e,
force 3000001 + 3e, contact 3000002 + 3e.
"""
import argparse
import glob
import hashlib
import json
import os
import sys
import zipfile
from xml.sax.saxutils import quoteattr

VR_INPUT, VR_PARAM, VR_ELEMENT = 1000000, 2000000, 3000000


def fail(message):
    print(f"trainsim: fmu: error: {message}", file=sys.stderr)
    sys.exit(2)


def binaries(exe_dir):
    """The directory holding trainsim_fmi2.so beside the executable (build tree or install)."""
    candidates = [os.path.join(exe_dir, "fmu")]
    candidates += [os.path.join(exe_dir, "..", "lib", "trainsim", "fmu")]
    candidates += glob.glob(os.path.join(exe_dir, "..", "lib", "*", "trainsim", "fmu"))
    env = os.environ.get("TRAINSIM_FMU_BINARIES")
    if env:
        candidates.insert(0, env)
    for c in candidates:
        if os.path.isfile(os.path.join(c, "trainsim_fmu.so")):
            return c
    fail("cannot find trainsim_fmu.so (looked in $TRAINSIM_FMU_BINARIES, " + ", ".join(candidates[-3:]) +
         "); build trainsim with its C interface (TRAINSIM_BUILD_C_API)")


INPUT_UNITS = {"speed": "rad/s", "voltage": "V"}
INPUT_NAMES = {"torque": "tau", "speed": "speed", "voltage": "voltage"}
INPUT_WHAT = {"torque": "external torque on node", "speed": "prescribed speed of node",
              "voltage": "supply voltage of motor"}
FMI3_TYPE = {"real": "Float64", "integer": "Int32", "string": "String"}
FMI2_TYPE = {"real": "Real", "integer": "Integer", "string": "String"}


def input_name(i):
    return f"{i['node']}.{INPUT_NAMES[i['kind']]}"


def variables(v):
    """The FMU's variables, one list for both FMI versions: (name, value reference,
    causality, variability, description, unit, initial, start, type)."""
    out = []
    for k, node in enumerate(v["nodes"]):
        out.append((f"{node}.phi", 1 + 2 * k, "output", "continuous", f"angle of node {node}", "rad", "calculated", None,
                    "real"))
        out.append((f"{node}.w", 2 + 2 * k, "output", "continuous", f"speed of node {node}", "rad/s", "calculated",
                    None, "real"))
    for e, el in enumerate(v["elements"]):
        i = el["id"]
        out.append((f"{i}.disp", VR_ELEMENT + 3 * e, "output", "continuous", f"displacement of {i}", el["disp_unit"],
                    "calculated", None, "real"))
        out.append((f"{i}.force", VR_ELEMENT + 3 * e + 1, "output", "continuous", f"force (or torque) of {i}",
                    el["force_unit"], "calculated", None, "real"))
        out.append((f"{i}.contact", VR_ELEMENT + 3 * e + 2, "output", "discrete",
                    f"contact state of {i}: 0 open, +1/-1 a face in contact", "1", "calculated", None, "real"))
    for j, i in enumerate(v["inputs"]):
        out.append((input_name(i), VR_INPUT + j, "input", "continuous", f"{INPUT_WHAT[i['kind']]} {i['node']}",
                    INPUT_UNITS.get(i["kind"], v["torque_unit"]), None, float(i["start"]), "real"))
    for p, par in enumerate(v["parameters"]):
        t = par.get("type", "real")
        start = float(par["value"]) if t == "real" else int(par["value"]) if t == "integer" else str(par["value"])
        out.append((par["path"], VR_PARAM + p, "parameter", "fixed", f"deck value {par['path']}", "1", "exact",
                    start, t))
    return out


def xml_start(start):
    return quoteattr(repr(start) if isinstance(start, float) else str(start))


def variable_row(fmi, name, vr, causality, variability, description, unit, initial, start, typ):
    """One variable of modelDescription.xml (FMI 3.0: <Float64 .../>, <Int32 .../>, <String><Start/></String>;
    2.0: <ScalarVariable> around <Real/>, <Integer/>, <String/>)."""
    attrs = f'name={quoteattr(name)} valueReference="{vr}" causality="{causality}" variability="{variability}"'
    if initial:
        attrs += f' initial="{initial}"'
    if fmi == 3:
        if typ == "string":
            return (f"    <String {attrs} description={quoteattr(description)}>\n"
                    f"      <Start value={xml_start(start)}/>\n    </String>")
        if start is not None:
            attrs += f" start={xml_start(start)}"
        unit_attr = f" unit={quoteattr(unit)}" if typ == "real" else ""
        return f"    <{FMI3_TYPE[typ]} {attrs}{unit_attr} description={quoteattr(description)}/>"
    attrs += f" description={quoteattr(description)}"
    inner = f"<{FMI2_TYPE[typ]}" + (f" unit={quoteattr(unit)}" if typ == "real" else "")
    inner += (f" start={xml_start(start)}" if start is not None else "") + "/>"
    return f"    <ScalarVariable {attrs}>\n      {inner}\n    </ScalarVariable>"


def model_description(v, guid, fmi):
    rows, outputs = [], []
    units = {"rad", "rad/s", "1", v["torque_unit"]}
    for var in variables(v):
        causality, unit, typ, vr = var[2], var[5], var[8], var[1]
        if typ == "real":
            units.add(unit)
        rows.append(variable_row(fmi, *var))
        if causality == "output":
            outputs.append(vr if fmi == 3 else len(rows))
    if fmi == 3:
        units.add("s")
        rows.insert(0, '    <Float64 name="time" valueReference="0" causality="independent" '
                       'variability="continuous" unit="s" description="time"/>')
    unit_defs = "\n".join(f"    <Unit name={quoteattr(u)}/>" for u in sorted(units))
    if fmi == 3:
        structure = "\n".join(f'    <Output valueReference="{r}"/>' for r in outputs)
        structure += "\n" + "\n".join(f'    <InitialUnknown valueReference="{r}"/>' for r in outputs)
        return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName={quoteattr(v["title"] or "trainsim")} instantiationToken="{guid}"
  description={quoteattr("trainsim drive train: " + os.path.basename(v["deck_file"]))}
  generationTool={quoteattr("trainsim " + v["version"])} variableNamingConvention="flat">
  <CoSimulation modelIdentifier="trainsim_fmu" canHandleVariableCommunicationStepSize="true"
    canGetAndSetFMUState="true" canSerializeFMUState="false" providesDirectionalDerivatives="false"
    providesAdjointDerivatives="false" hasEventMode="false" canReturnEarlyAfterIntermediateUpdate="false"
    providesIntermediateUpdate="false" providesEvaluateDiscreteStates="false"/>
  <UnitDefinitions>
{unit_defs}
  </UnitDefinitions>
  <ModelVariables>
{chr(10).join(rows)}
  </ModelVariables>
  <ModelStructure>
{structure}
  </ModelStructure>
</fmiModelDescription>
"""
    unknowns = "\n".join(f'      <Unknown index="{i}"/>' for i in outputs)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(v["title"] or "trainsim")} guid="{guid}"
  description={quoteattr("trainsim drive train: " + os.path.basename(v["deck_file"]))}
  generationTool={quoteattr("trainsim " + v["version"])} variableNamingConvention="flat"
  numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="trainsim_fmu" canHandleVariableCommunicationStepSize="true"
    canGetAndSetFMUstate="true" canSerializeFMUstate="false" canNotUseMemoryManagementFunctions="true"
    canInterpolateInputs="false" providesDirectionalDerivative="false"/>
  <UnitDefinitions>
{unit_defs}
  </UnitDefinitions>
  <ModelVariables>
{chr(10).join(rows)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>
{unknowns}
    </Outputs>
    <InitialUnknowns>
{unknowns}
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


def parameter_line(p):
    """TYPE<TAB>VALUE of parameters.txt: r a real (repr), i an integer, s a text."""
    t = p.get("type", "real")
    if t == "real":
        return f"r\t{float(p['value'])!r}"
    return f"i\t{int(p['value'])}" if t == "integer" else f"s\t{p['value']}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("variables", help="the JSON that trainsim fmu wrote")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--exe-dir", default=".")
    ap.add_argument("--fmi", type=int, choices=(2, 3), default=3)
    a = ap.parse_args()
    with open(a.variables) as f:
        v = json.load(f)
    deck_dir = os.path.dirname(os.path.abspath(v["deck_file"]))
    with open(v["deck_file"], "rb") as f:
        deck = f.read()
    tables = []
    for t in v["table_files"]:
        rel = os.path.normpath(t)
        if os.path.isabs(t) or rel.startswith(".."):
            fail(f"table_file '{t}': an FMU carries the files beside its deck only (a path below the deck's "
                 "folder); copy the table there")
        tables.append(rel)
    bindir = binaries(a.exe_dir)
    digest = hashlib.sha256(deck + json.dumps(v, sort_keys=True).encode()).hexdigest()
    guid = "{%s-%s-%s-%s-%s}" % (digest[:8], digest[8:12], digest[12:16], digest[16:20], digest[20:32])
    tmp = a.output + ".part"
    try:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("modelDescription.xml", model_description(v, guid, a.fmi))
            z.writestr("resources/deck.nml", deck)
            z.writestr("resources/inputs.txt", "".join(f"{input_name(i)}\t{float(i['start'])!r}\n"
                                                       for i in v["inputs"]))
            z.writestr("resources/parameters.txt", "".join(f"{p['path']}\t{parameter_line(p)}\n"
                                                           for p in v["parameters"]))
            for rel in tables:
                z.write(os.path.join(deck_dir, rel), "resources/" + rel)
            for lib in sorted(os.listdir(bindir)):
                if lib.endswith(".so") or ".so." in lib:
                    platform = "x86_64-linux" if a.fmi == 3 else "linux64"
                    z.write(os.path.join(bindir, lib), f"binaries/{platform}/" + lib)
        os.replace(tmp, a.output)
    except OSError as exc:
        if os.path.exists(tmp):
            os.remove(tmp)
        fail(f"cannot write '{a.output}': {exc.strerror}")
    print(f"trainsim: fmu: {a.output} (FMI {a.fmi}.0): {len(v['nodes'])} nodes (angle, speed outputs), "
          f"{len(v['elements'])} elements (displacement, force, contact outputs), {len(v['inputs'])} input(s), "
          f"{len(v['parameters'])} parameters")


if __name__ == "__main__":
    main()
