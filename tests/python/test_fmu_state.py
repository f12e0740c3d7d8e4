"""FMU state through fmpy: a rollout resumed from a saved state, and from a serialized then
deserialized one (also in a fresh instance), matches the uninterrupted rollout bit for bit; a
state of another scene or corrupt bytes are refused; the tunable scm.eps2 changed between
steps takes effect, and fmi2Reset restores it."""
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from hosts import Opened

H = 0.01


def outputs(f):
    return [v.valueReference for v in f.md.modelVariables if v.causality == "output"]


def rollout(f, slave, first, n):
    """n steps from step `first`, with a control signal that changes every step; every output
    after each step, as raw bits."""
    inputs = [v.valueReference for v in f.md.modelVariables if v.causality == "input"]
    rows = []
    for k in range(first, first + n):
        if inputs:
            slave.setReal(inputs, [0.1 + 0.05 * np.sin(0.3 * (k + i)) for i in range(len(inputs))])
        slave.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
        rows.append(np.array(slave.getReal(outputs(f))).view(np.uint64))
    return np.array(rows)


@pytest.mark.parametrize("name", ["sphere_drop", "t_push", "adhesion_pick"])
def test_resume_from_saved_and_serialized_state_is_bit_identical(fmu, name):
    f = Opened(fmu(name))
    slave = f.instance("CS")
    rollout(f, slave, 0, 40)
    state = slave.getFMUstate()
    reference = rollout(f, slave, 40, 30)

    slave.setFMUstate(state)
    assert np.array_equal(rollout(f, slave, 40, 30), reference), "resumed from fmi2GetFMUstate"

    data = slave.serializeFMUstate(state)
    restored = slave.deSerializeFMUstate(data)
    slave.setFMUstate(restored)
    assert np.array_equal(rollout(f, slave, 40, 30), reference), "resumed from a deserialized state"

    fresh = f.instance("CS", name="fresh")
    fresh.setFMUstate(fresh.deSerializeFMUstate(bytes(data)))
    assert np.array_equal(rollout(f, fresh, 40, 30), reference), "resumed in another instance"
    for s in (state, restored):
        slave.freeFMUstate(s)
    for inst in (slave, fresh):
        inst.terminate()
        inst.freeInstance()


def test_foreign_and_corrupt_states_are_refused(fmu):
    pair, drop = Opened(fmu("sphere_pair")), Opened(fmu("sphere_drop"))
    a = pair.instance("CS")
    a.doStep(currentCommunicationPoint=0.0, communicationStepSize=H)
    data = bytes(a.serializeFMUstate(a.getFMUstate()))
    b = drop.instance("CS")
    b.doStep(currentCommunicationPoint=0.0, communicationStepSize=H)
    before = b.getReal(outputs(drop))
    with pytest.raises(FMICallException):
        b.deSerializeFMUstate(data)
    corrupt = bytearray(data)
    corrupt[len(corrupt) // 2] ^= 0x01
    with pytest.raises(FMICallException):
        a.deSerializeFMUstate(bytes(corrupt))
    with pytest.raises(FMICallException):
        a.deSerializeFMUstate(data[:-9])
    assert b.getReal(outputs(drop)) == before, "a refused state changed the instance"
    b.doStep(currentCommunicationPoint=H, communicationStepSize=H)


def test_tunable_eps2_takes_effect_between_steps_and_reset_restores_it(fmu):
    f = Opened(fmu("sphere_drop"))
    slave = f.instance("CS")
    eps2, fz = f.vr["scm.eps2"], f.vr["contact.world.ball.force.z"]
    (start,) = slave.getReal([eps2])
    for k in range(60):
        slave.doStep(currentCommunicationPoint=k * H, communicationStepSize=H)
    saved = slave.getFMUstate()
    slave.doStep(currentCommunicationPoint=0.6, communicationStepSize=H)
    (same,) = slave.getReal([fz])
    slave.setFMUstate(saved)
    # Annealing the other way: a 10x wider separation distribution spreads the ball's weight
    # over more points of its point cloud, which changes the force at once.
    slave.setReal([eps2], [10 * start])
    slave.doStep(currentCommunicationPoint=0.6, communicationStepSize=H)
    (wider,) = slave.getReal([fz])
    assert abs(wider - same) > 1e-3 * abs(same), (same, wider)
    slave.reset()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    assert slave.getReal([eps2]) == [start]
    slave.exitInitializationMode()
    slave.terminate()
    slave.freeInstance()
