"""libcosimpy (the Open Simulation Platform's libcosim, from PyPI) as a host: it simulates
sphere_drop for 2 s and matches fmpy's run of the same FMU.

libcosim runs each slave's fmi2DoStep from a worker thread and keeps time as integer
nanoseconds, so its communication points are k x 10 ms converted from nanoseconds, which can
differ from fmpy's k x 0.01 in the last bit; the step sizes then differ by about 1e-18 s, the
internal steps by as much, and the outputs by rounding-level amounts. Tolerance as for the
regression references (tests/python/test_references.py, where the amplification of
rounding-level perturbations was measured at 70x at most): 1e-7 of each column's largest
magnitude plus 1e-9.
"""
import numpy as np
from fmpy import read_model_description, simulate_fmu


def test_libcosimpy_simulates_sphere_drop_like_fmpy(fmu):
    from libcosimpy.CosimEnums import CosimExecutionState
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.WARNING)
    path = fmu("sphere_drop")
    md = read_model_description(path)
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    execution = CosimExecution.from_step_size(step_size=10_000_000)  # 10 ms, in ns
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=path, instance_name="ball"))
    assert index == 0
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    refs = [v.valueReference for v in outputs]
    rows = []
    for _ in range(200):
        assert execution.step(), "libcosim step failed"
        rows.append(observer.last_real_values(index, refs))
    assert execution.status().error_code == 0
    assert execution.status().state == CosimExecutionState.STOPPED.value
    cosim = np.array(rows)
    ref = simulate_fmu(path, stop_time=2.0, output_interval=0.01, output=[v.name for v in outputs])
    for j, v in enumerate(outputs):
        y_ref = ref[v.name][1:]
        tol = 1e-7 * np.max(np.abs(y_ref)) + 1e-9
        err = np.max(np.abs(cosim[:, j] - y_ref))
        assert err <= tol, f"{v.name}: libcosim and fmpy differ by {err} (tolerance {tol})"
    # The ball fell and came to rest on the plane in both.
    z = cosim[:, refs.index(next(v.valueReference for v in outputs if v.name == "ball.pos.z"))]
    assert 0.045 < z[-1] < 0.05, z[-1]
