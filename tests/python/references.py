"""Regression references: for every bundled scene, a CSV of all its outputs over the scene's
default experiment (2 s, every 10 ms), simulated by fmpy in Co-Simulation, checked in under
tests/reference/<scene>.csv and compared by test_references.py.

Regenerate deliberately (after a change of behaviour you meant), then review and commit the
CSVs:

    scripts/regenerate_references.sh            # every scene
    scripts/regenerate_references.sh t_push     # some scenes

A scene whose outputs should be exercised by inputs gets them in INPUTS below (held constant
from t = 0, set as start values, so the run is the same in every host), or, for inputs that
must move (a mocap body), a signal in SIGNALS: input values at the communication points, which
fmpy sets before each step.
"""
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
REFERENCE_DIR = ROOT / "tests" / "reference"
STOP_TIME = 2.0
OUTPUT_INTERVAL = 0.01

#: Constant inputs per scene (the rest run with their start values).
INPUTS = {
    "t_push": {"act_y.ctrl": 0.16, "act_x.ctrl": 0.01},
}

#: Time-varying inputs per scene: {input: function of time}, sampled at the communication points.
SIGNALS = {
    # The paddle starts 3 cm behind the box and moves +x at 10 cm/s for 1.5 s, then stops: it
    # reaches the box at 0.3 s and pushes it about 12 cm.
    "mocap_push": {"paddle.pos.x": lambda t: -0.11 + 0.1 * np.minimum(t, 1.5)},
    # The pad grips the box from the start, lifts it 4 cm between 0.4 s and 0.9 s, and lets go
    # at 1.5 s: the box drops back to the floor.
    "adhesion_pick": {
        "grip.ctrl": lambda t: np.where(t < 1.5, 1.0, 0.0),
        "lift.ctrl": lambda t: 0.04 * np.clip((t - 0.4) / 0.5, 0.0, 1.0),
    },
}

REGENERATE = "scripts/regenerate_references.sh"


def input_signal(name):
    """The structured input array fmpy takes for a scene's SIGNALS, or None."""
    signals = SIGNALS.get(name)
    if not signals:
        return None
    t = np.arange(0.0, STOP_TIME + OUTPUT_INTERVAL / 2, OUTPUT_INTERVAL)
    out = np.zeros(len(t), dtype=[("time", float)] + [(k, float) for k in signals])
    out["time"] = t
    for k, f in signals.items():
        out[k] = f(t)
    return out


def reference_path(name):
    return REFERENCE_DIR / f"{name}.csv"


def simulate(fmu_path, name):
    """The reference run of a scene's FMU: a structured array of time and every output."""
    from fmpy import read_model_description, simulate_fmu
    md = read_model_description(fmu_path)
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    return simulate_fmu(fmu_path, stop_time=STOP_TIME, output_interval=OUTPUT_INTERVAL, output=outputs, start_values=INPUTS.get(name, {}), input=input_signal(name))


def write_csv(result, path):
    names = result.dtype.names
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for row in result:
            f.write(",".join(repr(float(row[n])) for n in names) + "\n")


def read_csv(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return header, data


def main(names):
    scenes = sorted(p.stem for p in (ROOT / "resources" / "scenes").glob("*.xml"))
    unknown = [n for n in names if n not in scenes]
    if unknown:
        sys.exit(f"no such scene: {', '.join(unknown)} (scenes: {', '.join(scenes)})")
    REFERENCE_DIR.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names or scenes:
            fmu = pathlib.Path(tmp) / f"{name}.fmu"
            subprocess.run([str(ROOT / "target" / "release" / "scm"), "pack", str(ROOT / "resources" / "scenes" / f"{name}.xml"), "-o", str(fmu)], check=True)
            write_csv(simulate(str(fmu), name), reference_path(name))
            print(f"wrote {reference_path(name).relative_to(ROOT)}")


if __name__ == "__main__":
    main(sys.argv[1:])
