"""Regression: every bundled scene's FMU reproduces its checked-in reference CSV
(tests/reference/<scene>.csv, written by tests/python/references.py), so any change of
behaviour shows.

Tolerance, per output column: |y - y_ref| <= 1e-7 * max_t |y_ref| + 1e-9 (SI units). The FMU
is deterministic, so on the machine that wrote the references the runs are bit-identical; the
tolerance is for other compilers, CPUs and libm versions, whose results differ in the last
bits. Measured: perturbing scm.eps2 or scm.stiffness by 1e-13 (relative) changes every output
by at most 7e-12 of its column's largest magnitude (t_push, whose smoothed dry friction
amplifies most; 1e-13 for the spheres), so rounding-level differences stay five orders of
magnitude inside the tolerance, while any change of the physics (a parameter changed by 1e-6,
a different force law, integrator or step) exceeds it. The 1e-9 floor covers columns that are
physically zero and carry only round-off (measured up to 1e-11).

A scene without a reference fails with the command that creates it.
"""
import numpy as np
import pytest

import references as R
from conftest import ALL_SCENES, ROOT


@pytest.mark.parametrize("name", ALL_SCENES)
def test_scene_reproduces_its_reference(fmu, name):
    path = R.reference_path(name)
    if not path.exists():
        pytest.fail(f"scene {name} has no regression reference {path.relative_to(ROOT)}: create it with "
                    f"`{R.REGENERATE} {name}`, check that the run looks right, and commit the CSV")
    header, ref = R.read_csv(path)
    result = R.simulate(fmu(name), name)
    names = list(result.dtype.names)
    assert names == header, (f"{name}: the outputs changed ({sorted(set(names) ^ set(header))}); if deliberate, "
                             f"regenerate with `{R.REGENERATE} {name}`")
    assert len(result) == len(ref), f"{name}: {len(result)} rows, the reference has {len(ref)}"
    problems = []
    for j, n in enumerate(names):
        y, y_ref = result[n], ref[:, j]
        tol = 1e-7 * np.max(np.abs(y_ref)) + 1e-9
        err = np.abs(y - y_ref)
        if np.any(err > tol):
            i = int(np.argmax(err - tol))
            problems.append(f"{n} at t = {ref[i, 0]}: {y[i]!r} vs reference {y_ref[i]!r} (tolerance {tol:.3g})")
    assert not problems, (f"{name} no longer reproduces {path.relative_to(ROOT)}:\n  " + "\n  ".join(problems)
                          + f"\nIf the change of behaviour is deliberate: `{R.REGENERATE} {name}`, review, commit.")
