"""Simulate the sphere_drop FMU in fmpy (Co-Simulation), write a CSV and a plot.

usage: simulate_sphere_drop.py FMU OUT.csv OUT.png
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from fmpy import simulate_fmu


def main(fmu, csv, png):
    outputs = ["ball.pos.z", "ball.linvel.z", "contact.world.ball.force.z", "contact.world.ball.distance"]
    res = simulate_fmu(fmu, stop_time=1.5, output_interval=0.002, output=outputs)
    np.savetxt(csv, np.column_stack([res[n] for n in ["time"] + outputs]), delimiter=",",
               header=",".join(["time"] + outputs), comments="")
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    ax1.plot(res["time"], res["ball.pos.z"] * 1000)
    ax1.set_ylabel("height of the centre (mm)")
    ax1.axhline(50, color="gray", lw=0.5, ls="--", label="radius")
    ax1.legend()
    # The FMU reports the force on the first body of the pair (the world); the ball gets -F.
    ax2.plot(res["time"], -res["contact.world.ball.force.z"])
    ax2.axhline(9.81, color="gray", lw=0.5, ls="--", label="weight m g")
    ax2.set_ylabel("contact force on the ball (N)")
    ax2.set_xlabel("time (s)")
    ax2.legend()
    fig.suptitle("sphere_drop: a 1 kg sphere of radius 5 cm dropped from 30 cm (SCM, fmpy)")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    rest = res["ball.pos.z"][-1]
    print(f"wrote {csv} and {png}; resting height {rest * 1000:.3f} mm "
          f"(penetration {(0.05 - rest) * 1000:.3f} mm)")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
