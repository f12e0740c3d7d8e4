"""Compiler differential test: the model scm compiles from an MJCF file equals MuJoCo's compiled
MjModel (MuJoCo's own Python package is the oracle), on every MuJoCo model that ships with
gymnasium and on every bundled scene.

Compared to 1e-9 (relative to the quantity's size where it is larger than 1): body frames,
masses, centres of mass and inertias; joint kinds, anchors, axes, reference and spring
positions, passive properties, limits and the limit springs' stiffness and damping; geom kinds,
sizes and poses (per body, in order); fixed tendons (joints, coefficients, spring, damper,
friction, spring length, limits); joint and tendon equalities (polynomial, spring and damper); connect equalities (bodies, anchors,
spring and damper);
actuator joints, gears, gains and biases, control and force ranges, joints' actuator force ranges; the time step and gravity; geom sliding
friction and condim.
"""
import json
import pathlib
import subprocess

import gymnasium
import mujoco
import numpy as np
import pytest

from conftest import DM_CONTROL, DM_CONTROL_MORE, DM_CONTROL_REFUSED, DM_CONTROL_SUITE, ROBOTICS, ROBOTICS_REFUSED, SCENES, SCM, dm_id, robotics_id

TOL = 1e-9
#: For what SCM and MuJoCo both derive from the mass matrix at qpos0 (a limit's spring from
#: 1/dof_invweight0): MuJoCo keeps mesh vertices in single precision after centring them, so
#: the inertias of bodies weighed by meshes agree to ~1e-10 in absolute terms, and M⁻¹ carries
#: that (the Franka kitchen's arm: 2e-9).
TOL_FROM_M = 1e-8

CORPUS_DIR = pathlib.Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets"
CORPUS = sorted(CORPUS_DIR.glob("*.xml"))
BUNDLED = sorted(SCENES.glob("*.xml"))

JOINT_TYPES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "free",
    int(mujoco.mjtJoint.mjJNT_BALL): "ball",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}
GEOM_TYPES = {
    int(mujoco.mjtGeom.mjGEOM_PLANE): "plane",
    int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
    int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule",
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID): "ellipsoid",
    int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
    int(mujoco.mjtGeom.mjGEOM_BOX): "box",
    int(mujoco.mjtGeom.mjGEOM_MESH): "mesh",
    # A height field flat when compiled is the plane of its surface in SCM.
    int(mujoco.mjtGeom.mjGEOM_HFIELD): "plane",
}


def compiled(path):
    """scm's compiled model of a file, as JSON."""
    out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def rot(quat):
    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, np.asarray(quat, dtype=float) / np.linalg.norm(quat))
    return m.reshape(3, 3)


def close(what, ours, theirs, tol=TOL):
    ours, theirs = np.asarray(ours, dtype=float), np.asarray(theirs, dtype=float)
    assert ours.shape == theirs.shape, f"{what}: shape {ours.shape} vs MuJoCo's {theirs.shape}"
    scale = np.maximum(1.0, np.abs(theirs))
    err = np.max(np.abs(ours - theirs) / scale) if ours.size else 0.0
    assert err <= tol, f"{what}: scm {ours.tolist()} vs MuJoCo {theirs.tolist()} (error {err:.2e})"


def refsafe_held(m, solref):
    """`solref` as MuJoCo's refsafe holds a constraint's: a time constant no less than twice the
    step, unless the flag is off; direct (negative) values as they are."""
    tau, zeta = solref
    if tau > 0 and not disabled(m, "REFSAFE"):
        tau = max(tau, 2 * m.opt.timestep)
    return tau, zeta


def limit_statics_gain(m, solimp, tendon):
    """The factor SCM stiffens a limit's reference gains by (docs/mjcf.md, "Joint limits"),
    1 / (1 - dmax), and the inertia it adds to a joint's coordinate, as a multiple of the
    joint's effective inertia: a joint's limit is stiffened under every integrator, with the
    added inertia (gain - 1) where the step does not take its damping implicitly (all but
    MuJoCo's implicit and implicitfast, and its Euler unless eulerdamp is off); a tendon's is
    stiffened and adds (gain - 1) of the tendon's inertia along its row under every integrator
    (docs/mjcf.md, "Equality constraints", "Rows across branches")."""
    i = m.opt.integrator
    gain = 1.0 / (1.0 - min(max(solimp[1], 1e-4), 0.9999))
    implicit = i in (mujoco.mjtIntegrator.mjINT_IMPLICIT, mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
    euler = i == mujoco.mjtIntegrator.mjINT_EULER and not disabled(m, "EULERDAMP")
    if tendon:
        return gain, gain - 1.0
    return gain, (0.0 if implicit or euler else gain - 1.0)


def disabled(m, flag):
    """Whether the file's <option><flag> switched `flag` (mjDSBL_<flag>) off."""
    return bool(m.opt.disableflags & int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag}")))


def mesh_frame(m, g):
    """MuJoCo moves a mesh geom's frame to the mesh's inertial frame; undo that, so the pose
    compares with the geom frame as written (which scm keeps)."""
    mesh = m.geom_dataid[g]
    pos, quat = m.geom_pos[g].copy(), m.geom_quat[g].copy()
    inv_pos, inv_quat = np.zeros(3), np.zeros(4)
    mujoco.mju_negPose(inv_pos, inv_quat, m.mesh_pos[mesh], m.mesh_quat[mesh])
    out_pos, out_quat = np.zeros(3), np.zeros(4)
    mujoco.mju_mulPose(out_pos, out_quat, pos, quat, inv_pos, inv_quat)
    return out_pos, out_quat


def compare(path, inertia_tol=TOL):
    ours = compiled(path)
    m = mujoco.MjModel.from_xml_path(str(path))

    # Option.
    close("timestep", ours["option"]["timestep"], m.opt.timestep)
    # <flag gravity="disable"> keeps MuJoCo's opt.gravity and skips it at run time; SCM's
    # compiled model has no gravity then.
    gravity = 0 * m.opt.gravity if disabled(m, "GRAVITY") else m.opt.gravity
    close("gravity", ours["option"]["gravity"], gravity)

    # Bodies, in MuJoCo's order (depth first, file order): frames and inertias.
    assert len(ours["bodies"]) == m.nbody, "body count"
    for b, body in enumerate(ours["bodies"]):
        tag = f"body {body['name']}"
        if b > 0:
            assert body["parent"] == ours["bodies"][m.body_parentid[b]]["name"], tag
        close(f"{tag} pos", body["pos"], m.body_pos[b])
        close(f"{tag} rotation", rot(body["quat"]), rot(m.body_quat[b]))
        close(f"{tag} mass", body["mass"], m.body_mass[b])
        # SCM drops gravity compensation where MuJoCo skips it at run time.
        passive_off = mujoco.mjtDisableBit.mjDSBL_SPRING | mujoco.mjtDisableBit.mjDSBL_DAMPER
        if m.opt.disableflags & passive_off != passive_off:
            close(f"{tag} gravcomp", body["gravcomp"], m.body_gravcomp[b])
        if m.body_mass[b] > 0:
            close(f"{tag} centre of mass", body["ipos"], m.body_ipos[b])
            r = rot(m.body_iquat[b])
            inertia = r @ np.diag(m.body_inertia[b]) @ r.T
            close(f"{tag} inertia", np.reshape(body["inertia"], (3, 3)), inertia, inertia_tol)

    # Joints, in order.
    assert len(ours["joints"]) == m.njnt, "joint count"
    for j, joint in enumerate(ours["joints"]):
        tag = f"joint {joint['name']}"
        kind = JOINT_TYPES[int(m.jnt_type[j])]
        assert joint["type"] == kind, tag
        assert joint["body"] == ours["bodies"][m.jnt_bodyid[j]]["name"], tag
        dof = m.jnt_dofadr[j]
        close(f"{tag} damping", joint["damping"], m.dof_damping[dof])
        close(f"{tag} armature", joint["armature"], m.dof_armature[dof])
        close(f"{tag} frictionloss", joint["frictionloss"], m.dof_frictionloss[dof])
        close(f"{tag} stiffness", joint["stiffness"], m.jnt_stiffness[j])
        assert joint["limited"] == bool(m.jnt_limited[j]), f"{tag} limited"
        if joint["limited"]:
            close(f"{tag} range", joint["range"], m.jnt_range[j])
        assert (joint["actuatorfrcrange"] is not None) == bool(m.jnt_actfrclimited[j]), f"{tag} actuatorfrclimited"
        if joint["actuatorfrcrange"] is not None:
            close(f"{tag} actuatorfrcrange", joint["actuatorfrcrange"], m.jnt_actfrcrange[j])
        if joint["limited"] and kind in ("slide", "hinge") and not disabled(m, "LIMIT"):
            # The limit spring and damper: MuJoCo's reference acceleration for the joint's
            # solreflimit, times the inertia its constraint sees (1 / dof_invweight0), stiffened
            # to MuJoCo's statics under the integrators that take the limit implicitly.
            tau, zeta = refsafe_held(m, m.jnt_solref[j])
            inertia = 1.0 / m.dof_invweight0[dof]
            if tau > 0:
                k, b = inertia / (tau * zeta) ** 2, 2 * inertia / tau
            else:
                k, b = -tau * inertia, -zeta * inertia
            gain, added = limit_statics_gain(m, m.jnt_solimp[j], tendon=False)
            k, b = k * gain, b * gain
            close(f"{tag} limit stiffness", joint["limit_stiffness"], k, TOL_FROM_M)
            close(f"{tag} limit damping", joint["limit_damping"], b, TOL_FROM_M)
            close(f"{tag} limit added inertia", joint["limit_added_inertia"], added * inertia, TOL_FROM_M)
        if kind in ("slide", "hinge"):
            close(f"{tag} pos", joint["pos"], m.jnt_pos[j])
            close(f"{tag} axis", joint["axis"], m.jnt_axis[j])
            qadr = m.jnt_qposadr[j]
            close(f"{tag} ref", joint["ref"], m.qpos0[qadr])
            close(f"{tag} springref", joint["springref"], m.qpos_spring[qadr])
        elif kind == "ball":
            close(f"{tag} pos", joint["pos"], m.jnt_pos[j])

    # Geoms, per body in order (MuJoCo numbers them body by body). A geom whose mesh is not a
    # closed surface and that neither collides nor carries mass is left out by SCM (listed as
    # unused): MuJoCo's is passed over, and must be such a geom.
    left_out = sum("geom left out" in u for u in ours["unused"])
    assert len(ours["geoms"]) + left_out == m.ngeom, "geom count"
    for b, body in enumerate(ours["bodies"]):
        mine = [g for g in ours["geoms"] if g["body"] == body["name"]]
        theirs = []
        for g in (g for g in range(m.ngeom) if m.geom_bodyid[g] == b):
            here = mine[len(theirs)] if len(theirs) < len(mine) else None
            is_mesh = int(m.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_MESH)
            mesh = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_MESH, m.geom_dataid[g]) if is_mesh else None
            kind = GEOM_TYPES[int(m.geom_type[g])]
            # Paired when the kind, the mesh and the collision bits agree (a left-out visual
            # geom shares its mesh with the colliding geom that follows it).
            bits = (int(m.geom_contype[g]), int(m.geom_conaffinity[g]))
            if here is not None and here["type"] == kind and here.get("mesh") == mesh \
                    and (here["contype"], here["conaffinity"]) == bits:
                theirs.append(g)
            else:
                assert mesh is not None and m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0, \
                    f"body {body['name']}: MuJoCo's geom {g} has no counterpart in SCM's model"
        assert len(mine) == len(theirs), f"geoms of body {body['name']}"
        for geom, g in zip(mine, theirs):
            tag = f"geom {geom['name']}"
            kind = GEOM_TYPES[int(m.geom_type[g])]
            assert geom["type"] == kind, tag
            if kind == "mesh":
                pos, quat = mesh_frame(m, g)
            else:
                pos, quat = m.geom_pos[g], m.geom_quat[g]
                # The entries of size that the geom type reads (MuJoCo keeps the rest as written).
                used = {"plane": 0, "sphere": 1, "capsule": 2, "cylinder": 2}.get(kind, 3)
                if used:
                    close(f"{tag} size", geom["size"][:used], m.geom_size[g][:used])
            close(f"{tag} pos", geom["pos"], pos)
            if geom.get("fitted_to") is None:
                close(f"{tag} rotation", rot(geom["quat"]), rot(quat))
            elif kind != "sphere":
                # A primitive fitted to a mesh lies along the mesh's principal axes, each of which
                # has two directions: the same shape whichever each engine took.
                same = np.abs(np.sum(rot(geom["quat"]) * rot(quat), axis=0))
                close(f"{tag} axes", same, np.ones(3))
            assert geom["contype"] == m.geom_contype[g], f"{tag} contype"
            assert geom["conaffinity"] == m.geom_conaffinity[g], f"{tag} conaffinity"
            assert geom["condim"] == m.geom_condim[g], f"{tag} condim"
            close(f"{tag} sliding friction", geom["friction"], m.geom_friction[g][0])

    # MuJoCo numbers fixed and spatial tendons together, in file order; SCM lists them apart,
    # each kind in file order.
    is_fixed = [int(m.wrap_type[m.tendon_adr[i]]) == int(mujoco.mjtWrap.mjWRAP_JOINT) for i in range(m.ntendon)]
    fixed = [i for i in range(m.ntendon) if is_fixed[i]]
    spatial = [i for i in range(m.ntendon) if not is_fixed[i]]
    tendon_names = [None] * m.ntendon
    for i, ten in zip(fixed, ours["tendons"]):
        tendon_names[i] = ten["name"]
    for i, ten in zip(spatial, ours["spatial_tendons"]):
        tendon_names[i] = ten["name"]

    # Actuators.
    assert len(ours["actuators"]) == m.nu, "actuator count"
    for a, act in enumerate(ours["actuators"]):
        tag = f"actuator {act['name']}"
        if int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_TENDON):
            assert act["tendon"] == tendon_names[m.actuator_trnid[a, 0]], tag
        elif int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_SITE):
            assert act["site"] == m.site(m.actuator_trnid[a, 0]).name, tag
            close(f"{tag} site gear", act["site_gear"], m.actuator_gear[a])
            assert act["gear"] == 1.0, tag
        elif int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_SLIDERCRANK):
            crank = act["slidercrank"]
            assert crank["cranksite"] == m.site(m.actuator_trnid[a, 0]).name, tag
            assert crank["slidersite"] == m.site(m.actuator_trnid[a, 1]).name, tag
            close(f"{tag} cranklength", crank["cranklength"], m.actuator_cranklength[a])
        elif int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_BODY):
            assert act["body"] == m.body(m.actuator_trnid[a, 0]).name, tag
        else:
            assert int(m.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT), tag
            assert act["joint"] == ours["joints"][m.actuator_trnid[a, 0]]["name"], tag
        # A site's gear is its 6-vector (above); MuJoCo's body transmission reads none.
        if act["site"] is None and act["body"] is None:
            close(f"{tag} gear", act["gear"], m.actuator_gear[a, 0])
        assert act["ctrllimited"] == bool(m.actuator_ctrllimited[a]), f"{tag} ctrllimited"
        if act["ctrllimited"]:
            close(f"{tag} ctrlrange", act["ctrlrange"], m.actuator_ctrlrange[a])
        # Every kind as MuJoCo stores it: the affine law's gain and bias (what MuJoCo reads of
        # them: the first entry of a fixed gain, nothing of a bias of type none).
        dyntype = {int(mujoco.mjtDyn.mjDYN_NONE): "none", int(mujoco.mjtDyn.mjDYN_INTEGRATOR): "integrator",
                   int(mujoco.mjtDyn.mjDYN_FILTER): "filter",
                   int(mujoco.mjtDyn.mjDYN_FILTEREXACT): "filterexact"}[int(m.actuator_dyntype[a])]
        assert act["dyntype"] == dyntype, f"{tag} dyntype"
        if dyntype in ("filter", "filterexact"):
            close(f"{tag} timeconst", act["timeconst"], m.actuator_dynprm[a, 0])
        assert act["actlimited"] == bool(m.actuator_actlimited[a]), f"{tag} actlimited"
        if act["actlimited"]:
            close(f"{tag} actrange", act["actrange"], m.actuator_actrange[a])
        assert act["actearly"] == bool(m.actuator_actearly[a]), f"{tag} actearly"
        assert act["actnum"] == m.actuator_actnum[a], f"{tag} actnum"
        affine_gain = int(m.actuator_gaintype[a]) == int(mujoco.mjtGain.mjGAIN_AFFINE)
        affine_bias = int(m.actuator_biastype[a]) == int(mujoco.mjtBias.mjBIAS_AFFINE)
        gain = m.actuator_gainprm[a, :3] if affine_gain else [m.actuator_gainprm[a, 0], 0, 0]
        bias = m.actuator_biasprm[a, :3] if affine_bias else [0, 0, 0]
        close(f"{tag} gain", act["gainprm"], gain)
        close(f"{tag} bias", act["biasprm"], bias)
        assert act["forcelimited"] == bool(m.actuator_forcelimited[a]), f"{tag} forcelimited"
        if act["forcelimited"]:
            close(f"{tag} forcerange", act["forcerange"], m.actuator_forcerange[a])

    def tendon_law(tag, ten, i):
        """A tendon's spring, damper, friction, spring length and limit spring, fixed or spatial."""
        on = lambda flag, x: 0.0 if disabled(m, flag) else x
        close(f"{tag} stiffness", ten["stiffness"], on("SPRING", m.tendon_stiffness[i]))
        close(f"{tag} damping", ten["damping"], on("DAMPER", m.tendon_damping[i]))
        close(f"{tag} frictionloss", ten["frictionloss"], on("FRICTIONLOSS", m.tendon_frictionloss[i]))
        close(f"{tag} springlength", ten["springlength"], m.tendon_lengthspring[i])
        limited = bool(m.tendon_limited[i]) and not disabled(m, "LIMIT")
        assert ten["limited"] == limited, f"{tag} limited"
        if limited:
            close(f"{tag} range", ten["range"], m.tendon_range[i])
            tau, zeta = refsafe_held(m, m.tendon_solref_lim[i])
            inertia = 1.0 / m.tendon_invweight0[i]
            k, b = (inertia / (tau * zeta) ** 2, 2 * inertia / tau) if tau > 0 else (-tau * inertia, -zeta * inertia)
            gain, added = limit_statics_gain(m, m.tendon_solimp_lim[i], tendon=True)
            k, b = k * gain, b * gain
            close(f"{tag} limit stiffness", ten["limit_stiffness"], k, TOL_FROM_M)
            close(f"{tag} limit damping", ten["limit_damping"], b, TOL_FROM_M)
            close(f"{tag} limit added inertia", ten["limit_added_inertia"], added * inertia, TOL_FROM_M)

    # Fixed tendons: joints and coefficients, spring, damper, friction, spring length (MuJoCo's
    # default is the length at qpos0), and the limit spring from solreflimit and
    # 1 / tendon_invweight0. Forces that a flag switches off are zero in SCM's model.
    assert len(ours["tendons"]) == len(fixed), "fixed tendon count"
    for i, ten in zip(fixed, ours["tendons"]):
        tag = f"tendon {ten['name']}"
        adr, num = m.tendon_adr[i], m.tendon_num[i]
        assert all(int(m.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT) for w in range(adr, adr + num)), tag
        assert [j for j, _ in ten["joints"]] == [ours["joints"][m.wrap_objid[w]]["name"] for w in range(adr, adr + num)], tag
        close(f"{tag} coefficients", [c for _, c in ten["joints"]], m.wrap_prm[adr:adr + num])
        tendon_law(tag, ten, i)

    # Spatial tendons: the segments between consecutive sites (bodies, the sites' points, 1 /
    # the divisor of the pulley branch), the length at qpos0, and the same spring, damper,
    # friction, spring length and limit spring as a fixed tendon's.
    assert len(ours["spatial_tendons"]) == len(spatial), "spatial tendon count"
    data0 = mujoco.MjData(m)
    mujoco.mj_forward(m, data0)
    for i, ten in zip(spatial, ours["spatial_tendons"]):
        tag = f"spatial tendon {ten['name']}"
        adr, num = m.tendon_adr[i], m.tendon_num[i]
        kinds = [int(m.wrap_type[w]) for w in range(adr, adr + num)]
        site, pulley = int(mujoco.mjtWrap.mjWRAP_SITE), int(mujoco.mjtWrap.mjWRAP_PULLEY)
        wrapping = {int(mujoco.mjtWrap.mjWRAP_SPHERE): "sphere", int(mujoco.mjtWrap.mjWRAP_CYLINDER): "cylinder"}
        assert set(kinds) <= {site, pulley} | set(wrapping), f"{tag}: sites, pulleys, spheres, cylinders"
        expected, scale = [], 1.0
        for w in range(adr, adr + num - 1):
            if kinds[w - adr] == pulley:
                scale = 1.0 / m.wrap_prm[w]
            elif kinds[w - adr] == site and kinds[w + 1 - adr] == site:
                expected.append((m.wrap_objid[w], m.wrap_objid[w + 1], scale, None))
            elif kinds[w - adr] == site and kinds[w + 1 - adr] in wrapping:
                # site, geom (with its side site in wrap_prm, -1 for none), site
                g = m.wrap_objid[w + 1]
                expected.append((m.wrap_objid[w], m.wrap_objid[w + 2], scale,
                                 (wrapping[kinds[w + 1 - adr]], g, int(round(m.wrap_prm[w + 1])))))
        assert len(ten["segments"]) == len(expected), f"{tag}: segments"
        for wrap, (_, _, _, want_wrap) in zip(ten["wraps"], expected):
            if want_wrap is None:
                assert wrap is None, tag
                continue
            kind, g, side = want_wrap
            assert wrap["shape"] == kind and wrap["body"] == ours["bodies"][m.geom_bodyid[g]]["name"], tag
            close(f"{tag} wrap radius", wrap["radius"], m.geom_size[g][0])
            close(f"{tag} wrap centre", wrap["pos"], m.geom_pos[g])
            assert (wrap["sidesite"] is None) == (side < 0), tag
            if side >= 0:
                close(f"{tag} side site", wrap["sidesite"][1], m.site_pos[side])
        for (b0, p0, b1, p1, sc), (s0, s1, want, _) in zip(ten["segments"], expected):
            assert b0 == ours["bodies"][m.site_bodyid[s0]]["name"], tag
            assert b1 == ours["bodies"][m.site_bodyid[s1]]["name"], tag
            close(f"{tag} site point", p0, m.site_pos[s0])
            close(f"{tag} site point", p1, m.site_pos[s1])
            close(f"{tag} scale", sc, want)
        close(f"{tag} length at qpos0", ten["length0"], data0.ten_length[i])
        tendon_law(tag, ten, i)

    # Joint and tendon equalities: the polynomial, and the spring and damper from solref and
    # MuJoCo's inverse weights of both objects.
    on = [e for e in range(m.neq) if not disabled(m, "EQUALITY") and m.eq_active0[e]]
    pointed = (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD))
    connects = [e for e in on if int(m.eq_type[e]) in pointed]
    eqs = [e for e in on if e not in connects]
    # Connects and welds: the bodies, both anchors (the one not written as MuJoCo's compiler
    # computes it at qpos0; a site's position for site semantics), a weld's held orientation,
    # and the springs and dampers from solref and the bodies' translational (rotational for a
    # weld's orientation) inverse weights.
    assert len(ours["connects"]) == len(connects), "connect count"
    for e, con in zip(connects, ours["connects"]):
        tag = f"{mujoco.mjtEq(m.eq_type[e]).name} {con['name']}"
        weld = int(m.eq_type[e]) == int(mujoco.mjtEq.mjEQ_WELD)
        sites = int(m.eq_objtype[e]) == int(mujoco.mjtObj.mjOBJ_SITE)
        obj1, obj2 = m.eq_obj1id[e], max(m.eq_obj2id[e], 0)
        b1, b2 = (m.site_bodyid[obj1], m.site_bodyid[obj2]) if sites else (obj1, obj2)
        assert con["body1"] == ours["bodies"][b1]["name"], tag
        assert con["body2"] == ours["bodies"][b2]["name"], tag
        data = m.eq_data[e]
        if sites:
            anchors = m.site_pos[obj1], m.site_pos[obj2]
        else:
            anchors = (data[3:6], data[0:3]) if weld else (data[0:3], data[3:6])
        close(f"{tag} anchor1", con["anchor1"], anchors[0])
        close(f"{tag} anchor2", con["anchor2"], anchors[1])
        solref = refsafe_held(m, m.eq_solref[e])

        def gains(w):
            if w == 0.0:  # neither body can move (or turn) that way: nothing to hold
                return 0.0, 0.0
            tau, zeta = solref
            return (1 / w / (tau * zeta) ** 2, 2 / w / tau) if tau > 0 else (-tau / w, -zeta / w)

        k, b = gains(m.body_invweight0[b1, 0] + (m.body_invweight0[b2, 0] if b2 > 0 else 0.0))
        close(f"{tag} stiffness", con["stiffness"], k)
        close(f"{tag} damping", con["damping"], b)
        held = weld and data[10] != 0.0
        assert (con["orientation"] is not None) == held, f"{tag}: orientation held"
        if held:
            if sites:
                relative = np.zeros(4)
                neg = np.zeros(4)
                mujoco.mju_negQuat(neg, m.site_quat[obj2])
                mujoco.mju_mulQuat(relative, m.site_quat[obj1], neg)
            else:
                relative = data[6:10]
            quat = np.asarray(con["orientation"]["relative"])
            close(f"{tag} orientation", quat * np.sign(quat @ relative), relative)
            k, b = gains(m.body_invweight0[b1, 1] + (m.body_invweight0[b2, 1] if b2 > 0 else 0.0))
            close(f"{tag} angular stiffness", con["orientation"]["stiffness"], k)
            close(f"{tag} angular damping", con["orientation"]["damping"], b)
    assert len(ours["equalities"]) == len(eqs), "equality count"
    for e, eq in zip(eqs, ours["equalities"]):
        tag = f"equality {eq['name']}"
        kind = int(m.eq_type[e])
        assert kind in (int(mujoco.mjtEq.mjEQ_JOINT), int(mujoco.mjtEq.mjEQ_TENDON)), tag
        close(f"{tag} polycoef", eq["poly"], m.eq_data[e, :5])
        joint = kind == int(mujoco.mjtEq.mjEQ_JOINT)
        # Each object's value at qpos0: a joint's reference, a tendon's length there.
        at_qpos0 = lambda i: m.qpos0[m.jnt_qposadr[i]] if joint else m.tendon_length0[i]
        close(f"{tag} reference", eq["reference"][0], at_qpos0(m.eq_obj1id[e]))
        if m.eq_obj2id[e] >= 0:
            close(f"{tag} reference 2", eq["reference"][1], at_qpos0(m.eq_obj2id[e]))
        weight = lambda i: m.dof_invweight0[m.jnt_dofadr[i]] if joint else m.tendon_invweight0[i]
        w = weight(m.eq_obj1id[e]) + (weight(m.eq_obj2id[e]) if m.eq_obj2id[e] >= 0 else 0.0)
        tau, zeta = refsafe_held(m, m.eq_solref[e])
        k, b = (1 / w / (tau * zeta) ** 2, 2 / w / tau) if tau > 0 else (-tau / w, -zeta / w)
        close(f"{tag} stiffness", eq["stiffness"], k)
        close(f"{tag} damping", eq["damping"], b)
    return ours


def test_the_corpus_is_there():
    assert len(CORPUS) == 14, [p.name for p in CORPUS]


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_corpus_file_compiles_as_mujoco_compiles_it(path):
    compare(path)


def test_the_dm_control_corpus_is_there():
    assert len(DM_CONTROL_SUITE) == 19, [p.name for p in DM_CONTROL_SUITE]
    assert all(p.exists() for p in DM_CONTROL_MORE), [p for p in DM_CONTROL_MORE if not p.exists()]
    assert len({dm_id(p) for p in DM_CONTROL}) == len(DM_CONTROL), "test ids are unique"


@pytest.mark.parametrize("path", DM_CONTROL, ids=[dm_id(p) for p in DM_CONTROL])
def test_dm_control_file_compiles_as_mujoco_compiles_it_or_is_refused_saying_why(path):
    mujoco.MjModel.from_xml_path(str(path))  # MuJoCo takes every file of the corpus
    if dm_id(path) in DM_CONTROL_REFUSED:
        where, why = DM_CONTROL_REFUSED[dm_id(path)]
        out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
        assert out.returncode != 0 and where in out.stderr and why in out.stderr, out.stderr
        return
    compare(path)


def test_the_robotics_corpus_is_there():
    assert len(ROBOTICS) == 17, [p.name for p in ROBOTICS]


@pytest.mark.parametrize("path", ROBOTICS, ids=[robotics_id(p) for p in ROBOTICS])
def test_robotics_file_compiles_as_mujoco_compiles_it_or_is_refused_saying_why(path):
    """gymnasium-robotics' files: the hands (their visual meshes, open surfaces, left out),
    Fetch (its gripper held to a mocap body by a weld), the Franka kitchen, the point maze."""
    mujoco.MjModel.from_xml_path(str(path))
    if robotics_id(path) in ROBOTICS_REFUSED:
        where, why = ROBOTICS_REFUSED[robotics_id(path)]
        out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
        assert out.returncode != 0 and where in out.stderr and why in out.stderr, out.stderr
        return
    compare(path)


@pytest.mark.parametrize("path", BUNDLED, ids=[p.stem for p in BUNDLED])
def test_bundled_scene_compiles_as_mujoco_compiles_it(path):
    ours = compare(path)
    assert ours["refused"] == [], "a bundled scene must simulate"


def test_tendons_and_tendon_actuators_compile_as_mujoco_compiles_them(tmp_path):
    from test_mjcf_idioms import TENDONS
    path = tmp_path / "tendons.xml"
    path.write_text(TENDONS.format(integrator="Euler"))
    ours = compare(path)
    assert [a.get("tendon") for a in ours["actuators"]] == ["couple", "band"]


def test_equalities_compile_as_mujoco_compiles_them(tmp_path):
    from test_mjcf_idioms import FOUR_BAR, GEARED_PENDULUMS, TENDONS
    path = tmp_path / "gear.xml"
    path.write_text(GEARED_PENDULUMS)
    assert len(compare(path)["equalities"]) == 1
    coupled = TENDONS.format(integrator="Euler").replace("</tendon>", """</tendon>
  <equality>
    <tendon tendon1="couple" tendon2="band" polycoef="0.01 -0.5 0.2 0 0" solref="0.05 0.8"/>
    <joint joint1="jc" polycoef="0.02 0 0 0 0" solref="-200 -3"/>
  </equality>""")
    path = tmp_path / "coupled.xml"
    path.write_text(coupled)
    assert len(compare(path)["equalities"]) == 2
    path = tmp_path / "four_bar.xml"
    path.write_text(FOUR_BAR)
    assert len(compare(path)["connects"]) == 1


LATE_JOINTS = """<mujoco>
  <worldbody>
    <body name="base" pos="0 0 1">
      <body name="arm" pos="0.2 0 0">
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <joint name="elbow" axis="0 1 0"/>
      </body>
      <geom type="box" size="0.1 0.1 0.1"/>
      <joint name="yaw" axis="0 0 1"/>
      <joint name="lift" type="slide" axis="0 0 1"/>
    </body>
    <body name="second" pos="1 0 1">
      <freejoint/>
      <geom type="sphere" size="0.1"/>
    </body>
    <geom name="floor" type="plane" size="2 2 0.1"/>
  </worldbody>
</mujoco>"""


def test_joints_written_after_child_bodies_are_numbered_body_by_body(tmp_path):
    """MuJoCo numbers joints, coordinates and geoms body by body (a body's own before its
    children's), wherever the file writes them: joints after a child body (dm_control's boxhead,
    rodent) and a world geom after the bodies. Compiled and moved as MuJoCo does."""
    from test_mjcf_dynamics import matches_mujoco
    path = tmp_path / "late.xml"
    path.write_text(LATE_JOINTS)
    ours = compare(path)
    assert [j["name"] for j in ours["joints"]] == ["yaw", "lift", "elbow", "second"]
    matches_mujoco(path, tmp_path)


WELDS = """<mujoco>
  <worldbody>
    <body name="hand" mocap="true" pos="0.3 0 1.2" euler="0 20 0"/>
    <body name="arm" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0"/>
      <joint name="twist" axis="1 0 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04"/>
      <site name="wrist" pos="0.3 0 0" euler="10 0 30"/>
      <body name="palm" pos="0.3 0 0" euler="0 0 15">
        <joint name="flex" axis="0 0 1"/>
        <geom type="box" size="0.05 0.03 0.02"/>
        <site name="tip" pos="0.05 0.01 0" euler="0 -40 0"/>
      </body>
    </body>
    <body name="puck" pos="0.6 0.2 0.5" euler="5 10 15">
      <freejoint/>
      <geom type="box" size="0.04 0.05 0.03" pos="0.01 0 0"/>
      <site name="top" pos="0 0 0.03"/>
    </body>
    <body name="slider" pos="-0.5 0 0.2">
      <joint type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.05"/>
    </body>
  </worldbody>
  <equality>
    <weld body1="hand" body2="palm" solref="0.02 1"/>
    <weld name="at" body1="puck" body2="arm" anchor="0.1 0.02 -0.03" torquescale="2" solref="0.05 0.7"/>
    <weld body1="puck" relpose="0.1 0.2 0.3 1 0.5 0 0" anchor="0.4 0.2 0.6"/>
    <weld body1="arm" body2="puck" torquescale="0"/>
    <weld site1="tip" site2="top" solref="-500 -20"/>
    <weld site1="wrist" site2="tip"/>
    <connect site1="wrist" site2="top"/>
    <weld body1="slider"/>
  </equality>
</mujoco>"""


def test_spatial_tendons_compile_as_mujoco_compiles_them(tmp_path):
    """Spatial tendons through sites, over pulleys, to the world, a mocap body and a free body,
    with a segment within one body, limits with their own solreflimit, and fixed tendons written
    between them (MuJoCo numbers both kinds together): segments, lengths at qpos0, spring
    lengths at the springs' rest pose, and the limit springs on 1 / tendon_invweight0; an
    actuator on a fixed tendon written after spatial ones names the right tendon, and servos on
    spatial tendons get MuJoCo's kv from their dampratio (the tendon's Jacobian at qpos0)."""
    from test_mjcf_idioms import SPATIAL_TENDONS
    xml = SPATIAL_TENDONS.format(integrator="Euler").replace(
        '<spatial name="rest" stiffness="3">', '<spatial name="rest" stiffness="3" range="0.1 0.4" solreflimit="0.05 0.7">'
    ).replace(
        '<spatial name="rope" stiffness="5"', '<spatial name="rope" limited="true" range="0 0.9" stiffness="5"'
    ).replace(
        '<joint name="jb" type="hinge" axis="0 1 0" damping="0.05"/>',
        '<joint name="jb" type="hinge" axis="0 1 0" damping="0.05" springref="20"/>',
    ).replace("</tendon>", """  <fixed name="late"><joint joint="jc" coef="2"/></fixed>
    <spatial name="leash" range="0 0.5" frictionloss="0.2">
      <site site="hand_site"/>
      <site site="ball_top"/>
      <pulley divisor="3"/>
      <site site="hook"/>
      <site site="c_site"/>
    </spatial>
  </tendon>
  <actuator><motor name="m" tendon="late"/><position name="p" tendon="couple" kp="4" dampratio="1"/>
    <position name="q" tendon="leash" kp="7" dampratio="0.8" gear="1.5"/></actuator>""").replace(
        "</worldbody>", """  <body name="hand" mocap="true" pos="1.5 0 1.6"><site name="hand_site"/></body>
  </worldbody>""")
    path = tmp_path / "strings.xml"
    path.write_text(xml)
    ours = compare(path)
    assert [t["name"] for t in ours["spatial_tendons"]] == ["rope", "band", "rest", "cord", "leash"]
    assert [t["limited"] for t in ours["spatial_tendons"]] == [True, False, True, False, True]


def test_a_servo_that_moves_nothing_at_qpos0_gets_mujocos_zero_damping(tmp_path):
    """Found by a random review: a position servo with dampratio on a string that lies straight
    along a hanging arm (its length does not change at qpos0, MuJoCo's inverse weight is 0):
    MuJoCo compiles kv = 0, and so does SCM (with a warning), where it refused the file."""
    path = tmp_path / "leash.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <site name="anchor" pos="0 0 -1"/>
    <body name="arm">
      <joint name="h" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.02"/>
      <site name="tip" pos="0 0 -0.5"/>
    </body>
  </worldbody>
  <tendon><spatial name="leash"><site site="tip"/><site site="anchor"/></spatial></tendon>
  <actuator><position name="servo" tendon="leash" kp="10" dampratio="1"/></actuator>
</mujoco>
""")
    ours = compare(path)
    assert ours["actuators"][0]["biasprm"][2] == 0.0
    assert [w for w in ours["warnings"] if "dampratio gives kv = 0" in w], ours["warnings"]


def test_wrapping_tendons_compile_as_mujoco_compiles_them(tmp_path):
    """Spatial tendons wrapping a sphere and a cylinder, one with a side site inside its geom,
    the geoms on moving bodies: segments, each wrap's geom (body, centre, radius) and side site,
    and the lengths at qpos0; a side site outside its geom is warned about (MuJoCo 4.0 departs
    from its published algorithm in some poses: docs/mjcf.md, "Spatial tendons")."""
    fixture = pathlib.Path(__file__).resolve().parents[1] / "fixtures" / "tendon_wrap.xml"
    ours = compare(fixture)
    assert [[w is not None for w in t["wraps"]] for t in ours["spatial_tendons"]] == [[True]] * 3
    assert not [w for w in ours["warnings"] if "side site" in w], ours["warnings"]
    path = tmp_path / "outside.xml"
    path.write_text(fixture.read_text().replace('<site name="core" pos="0.01 0 0"/>', '<site name="core" pos="0 0 0.2"/>'))
    ours = compare(path)
    assert [w for w in ours["warnings"] if "side site 'core' outside it" in w], ours["warnings"]


def test_site_transmissions_compile_as_mujoco_compiles_them(tmp_path):
    """Actuators on sites (a quadrotor's thrust and yaw torques, a servo and a damper on an
    arm's sites): the sites, their 6-vector gears, and a position servo's kv from dampratio on
    the site's moment at qpos0."""
    from test_mjcf_idioms import SITE_ACTUATORS
    path = tmp_path / "drone.xml"
    path.write_text(SITE_ACTUATORS)
    ours = compare(path)
    assert [a["site"] for a in ours["actuators"]] == ["r1", "r2", "r3", "r4", "tip", "bead", "tip"]


def test_slider_cranks_compile_as_mujoco_compiles_them(tmp_path):
    """Slider-crank transmissions: their sites, rod lengths and gears, and a position's kv from
    dampratio on the crank's moment at qpos0."""
    from test_mjcf_dynamics import SLIDER_CRANK
    path = tmp_path / "slider_crank.xml"
    path.write_text(SLIDER_CRANK)
    ours = compare(path)
    assert [a["slidercrank"]["cranklength"] for a in ours["actuators"]] == [0.08, 0.06, 0.05]


def test_welds_compile_as_mujoco_compiles_them(tmp_path):
    """Welds between bodies (to a mocap body, to the world, with an anchor, with relpose, with
    torquescale 0 and 2) and between sites, and a connect between sites: points, held
    orientations and the springs on MuJoCo's translational and rotational inverse weights."""
    path = tmp_path / "welds.xml"
    path.write_text(WELDS)
    ours = compare(path)
    assert [w for w in ours["warnings"] if 'torquescale="2"' in w and "welds.xml:27" in w], ours["warnings"]
    assert [c["orientation"] is not None for c in ours["connects"]] == [True, True, True, False, True, True, False, True]


def test_position_dampratio_compiles_as_mujoco_compiles_it(tmp_path):
    """`dampratio` sets kv from the inertia the actuator drives at qpos0 (its moment through
    M⁻¹), on a joint with a gear and on a fixed tendon; the compared biasprm holds kv."""
    path = tmp_path / "dampratio.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <body name="cart" pos="0 0 1">
      <joint name="s" type="slide" axis="1 0 0" armature="0.01"/>
      <geom type="box" size=".1 .1 .1"/>
      <body name="b1">
        <joint name="j1" axis="0 1 0" armature="0.05"/>
        <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
        <body name="b2" pos=".3 0 0">
          <joint name="j2" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
        </body>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="j1" coef="1"/><joint joint="j2" coef="-0.5"/></fixed></tendon>
  <default><position kp="40" dampratio="0.7"/></default>
  <actuator>
    <position joint="s" kp="100" dampratio="1"/>
    <position joint="j2" gear="2"/>
    <position tendon="t" kp="30" dampratio="1.5" gear="2"/>
  </actuator>
</mujoco>
""")
    ours = compare(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert all(m.actuator_biasprm[:, 2] < 0) and len(ours["actuators"]) == 3


def test_joint_springdamper_compiles_as_mujoco_compiles_it(tmp_path):
    """`springdamper="τ ζ"` replaces stiffness and damping with `I/(τζ)²` and `2I/τ`, `I` the
    joint's inertia at qpos0 (MuJoCo's 1/dof_invweight0), on coupled slide and hinge joints."""
    path = tmp_path / "springdamper.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <body name="cart" pos="0 0 1">
      <joint name="s" type="slide" axis="1 0 0" armature="0.02" springdamper="0.1 0.7"/>
      <geom type="box" size=".1 .1 .1"/>
      <body name="arm">
        <joint name="h" axis="0 1 0" armature="0.05" stiffness="5" springdamper="0.2 1.3"/>
        <geom type="capsule" fromto="0 0 0 .3 0 -.2" size=".02"/>
      </body>
    </body>
  </worldbody>
</mujoco>
""")
    compare(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert m.jnt_stiffness[1] != 5


def test_damper_actuators_compile_as_mujoco_compiles_them(tmp_path):
    """A damper is an affine gain on the actuator's velocity (`force = -kv L̇ u`), on a joint
    and on a fixed tendon; its kv defaults as MuJoCo's."""
    path = tmp_path / "damper.xml"
    path.write_text("""<mujoco>
  <worldbody>
    <body name="b1" pos="0 0 1">
      <joint name="j1" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
      <body name="b2" pos=".3 0 0">
        <joint name="j2" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="j1" coef="1"/><joint joint="j2" coef="1"/></fixed></tendon>
  <actuator>
    <damper joint="j1" kv="3" ctrlrange="0 1"/>
    <damper tendon="t" gear="2" ctrlrange="0 2"/>
  </actuator>
</mujoco>
""")
    ours = compare(path)
    assert [a["gainprm"][2] for a in ours["actuators"]] == [-3.0, 0.0]


ACTUATOR_KINDS = ["general", "motor", "position", "velocity", "damper", "intvelocity", "cylinder", "adhesion"]


def _actuator_attributes(rng, kind):
    """Attributes an actuator of `kind` may be given in a default or on the element."""
    a = {}
    if kind in ("position", "intvelocity"):
        if rng.random() < 0.5:
            a["kp"] = rng.choice(["3", "10"])
        x = rng.random()
        if x < 0.3:
            a["kv"] = rng.choice(["0", "2"])
        elif x < 0.5:
            a["dampratio"] = rng.choice(["0.5", "1"])
    elif kind in ("velocity", "damper") and rng.random() < 0.5:
        a["kv"] = rng.choice(["0", "4"])
    elif kind == "adhesion" and rng.random() < 0.5:
        a["gain"] = rng.choice(["2", "6"])
    elif kind == "cylinder":
        for key, values in (("timeconst", ["0.1", "2"]), ("area", ["3"]), ("diameter", ["0.5"]),
                            ("bias", ["1", "0 -2 -1"])):
            if rng.random() < 0.4:
                a[key] = rng.choice(values)
    elif kind == "general":
        if rng.random() < 0.4:
            a["gaintype"] = rng.choice(["fixed", "affine"])
        if rng.random() < 0.5:
            a["gainprm"] = rng.choice(["5", "5 0 -3", "7 1 2", "0 0 -2"])
        if rng.random() < 0.4:
            a["biastype"] = rng.choice(["none", "affine"])
        if rng.random() < 0.5:
            a["biasprm"] = rng.choice(["0 -5 -1", "1 2 3", "0 -7 2", "0 0 -6"])
    if kind != "adhesion" and rng.random() < 0.2:  # an adhesion has no gear (MuJoCo refuses it)
        a["gear"] = rng.choice(["2", "3"])
    if kind in ("damper", "adhesion") or rng.random() < 0.2:
        a["ctrlrange"] = rng.choice(["0 1", "0 2"])
    return a


def _actuator_element(kind, attributes, extra=""):
    return "<%s %s %s/>" % (kind, " ".join(f'{k}="{v}"' for k, v in attributes.items()), extra)


def _actuator_defaults_cases(n, seed=20261127):
    """`n` files: three nested default classes, each with up to three actuator defaults of
    distinct kinds in random order, and one actuator of a random kind in a random class."""
    import random
    rng = random.Random(seed)
    block = lambda: "".join(_actuator_element(k, _actuator_attributes(rng, k)) for k in rng.sample(ACTUATOR_KINDS, rng.randint(0, 3)))
    for _ in range(n):
        kind = rng.choice(ACTUATOR_KINDS)
        cls = rng.choice(["", 'class="c"', 'class="d"'])
        target = 'body="b"' if kind == "adhesion" else 'joint="j"'
        act = _actuator_element(kind, _actuator_attributes(rng, kind), f'{target} {cls}')
        yield f"""<mujoco>
  <default>{block()}<default class="c">{block()}<default class="d">{block()}</default></default></default>
  <worldbody><body name="b"><joint name="j" type="slide"/><geom size=".1" mass="2"/></body></worldbody>
  <actuator>{act}</actuator>
</mujoco>
"""


# (defaults, actuator): the cases the rules of docs/mjcf.md ("Actuator defaults") were read
# from, one MuJoCo behaviour each.
ACTUATOR_DEFAULTS_CASES = [
    # A position's inheritrange: its control range from its target's range.
    ('', '<position inheritrange="0.5"/>'),
    ('<position inheritrange="1"/>', '<motor/>'),
    ('<position inheritrange="1"/>', '<position ctrlrange="0 1"/>'),
    ('<position ctrlrange="0 0.5"/>', '<position inheritrange="1"/>'),
    ('', '<position inheritrange="1" ctrlrange="0 1"/>'),
    ('<general inheritrange="0.5"/>', '<position/>'),
    ('', '<general inheritrange="1"/>'),
    # A damper default switches the control limit on for its whole class.
    ('<motor ctrllimited="false"/><damper kv="1" ctrlrange="0 1"/>', '<position kp="5" ctrlrange="-1 1"/>'),
    ('<damper kv="4"/>', '<motor/>'),
    ('<damper ctrlrange="-1 1"/>', '<motor ctrlrange="0 1"/>'),
    # A position keeps a first-order filter from a <general> default (SCM refuses it).
    ('<position kp="10" timeconst="0.1"/><general gainprm="3"/>', '<position/>'),
    ('<general dyntype="filterexact" dynprm="0.2"/>', '<position/>'),
    ('<general dyntype="filter" dynprm="0.2"/>', '<position/>'),
    # A nested class written before its parent's own defaults inherits them all.
    ('<default class="c"/><position kp="10" kv="2" gear="3"/>', '<position class="c"/>'),
    ('<general gainprm="5 0 -3"/>', '<damper ctrlrange="0 1"/>'),
    ('<general gaintype="affine" gainprm="5 0 -3"/><default class="c"><general gaintype="fixed"/></default>', '<damper class="c" ctrlrange="0 1"/>'),
    ('<velocity kv="10"/>', '<position/>'),
    ('<position kp="10" kv="2"/>', '<velocity/>'),
    ('<velocity kv="10"/>', '<damper ctrlrange="0 1"/>'),
    ('<damper kv="4" ctrlrange="0 1"/>', '<damper/>'),
    ('<position kp="10" kv="1"/>', '<general/>'),
    ('<damper kv="4" ctrlrange="0 1"/>', '<motor/>'),
    ('<position kp="10" dampratio="1"/>', '<position kv="3"/>'),
    ('<position kp="10" dampratio="1"/>', '<position/>'),
    ('<position kp="10" dampratio="1"/>', '<general/>'),
    ('<general gainprm="5" biastype="affine" biasprm="1 2 3"/>', '<position/>'),
    ('<position kp="10" kv="1"/><velocity kv="3"/>', '<position/>'),
    ('<velocity kv="3"/><position kp="10"/>', '<position/>'),
    ('<position kp="10" kv="2"/><motor/>', '<position/>'),
    ('<velocity kv="10" gear="2"/>', '<motor/>'),
    ('<muscle/>', '<position/>'),
    ('<cylinder area="2"/>', '<general/>'),
    ('<default class="c"><velocity kv="10"/></default>', '<velocity class="c"/>'),
    ('<default class="c"><velocity kv="10"/></default>', '<position class="c"/>'),
    ('<default class="c"><velocity kv="10"/></default>', '<general class="c"/>'),
    ('<default class="c"><position kp="10" kv="2"/></default>', '<velocity class="c"/>'),
    ('<default class="c"><position kp="10" kv="2"/></default>', '<position class="c"/>'),
    ('<default class="c"><general gainprm="5" biastype="affine" biasprm="0 -5 -2"/></default>', '<position class="c"/>'),
    ('<default class="c"><general gainprm="5" biastype="affine" biasprm="0 -5 -2"/></default>', '<velocity class="c"/>'),
    ('<default class="c"><motor gear="3"/></default>', '<position class="c"/>'),
    ('<position kp="10" kv="2"/><general ctrlrange="-1 1"/>', '<velocity/>'),
    ('<position kp="10" kv="2"/><general ctrlrange="-1 1"/>', '<position/>'),
    ('<general gainprm="5"/><position kv="2"/>', '<position/>'),
    ('<general gainprm="5" biasprm="0 0 -9" biastype="affine"/><position kp="7"/>', '<position/>'),
    ('<general gainprm="5" biastype="affine" biasprm="0 -5 -2"/>', '<damper ctrlrange="0 1"/>'),
    ('<damper kv="4" ctrlrange="0 1"/>', '<general/>'),
    ('<position kp="10" kv="2"/><default class="c"><velocity kv="3"/></default>', '<position class="c"/>'),
    ('<position kp="10" kv="2"/><default class="c"><general ctrlrange="0 1"/></default>', '<position class="c"/>'),
    ('<velocity kv="3"/><default class="c"><position kp="7"/></default>', '<velocity class="c"/>'),
    ('<velocity kv="3"/><default class="c"><position kp="7"/></default>', '<position class="c"/>'),
    ('<position kp="10" kv="2"/>', '<position kv="5"/>'),
    ('<intvelocity kp="10"/>', '<position/>'),
    ('<damper kv="4" ctrlrange="0 1"/>', '<velocity/>'),
    ('<position kp="10" kv="2"/><general gainprm="3"/>', '<position/>'),
    ('<position kp="10" kv="2"/><general gainprm="3"/>', '<velocity/>'),
    ('<velocity kv="3"/><general ctrlrange="-1 1"/>', '<position/>'),
    ('<position kp="10" dampratio="1"/>', '<general biasprm="0 -10 -1"/>'),
    ('<position kp="10" kv="2" gear="2" forcerange="-1 1"/>', '<motor/>'),
    ('<position kp="10" kv="2"/><default class="c"><velocity kv="3" ctrlrange="0 1" gear="2"/></default>', '<position class="c"/>'),
    ('', '<general gainprm="10" biastype="affine" biasprm="0 -10 1"/>'),
    ('<position kp="10" kv="2"/><default class="c"><position kp="20"/></default>', '<position class="c"/>'),
    ('<general ctrlrange="0 1"/><default class="c"><position kp="20"/></default>', '<velocity class="c"/>'),
    ('<position kp="10" kv="2"/><default class="c"><velocity kv="3"/><general gear="2"/></default>', '<position class="c"/>'),
    ('<position kp="10" kv="2"/><default class="c"><velocity kv="3"/><general gear="2"/></default>', '<motor class="c"/>'),
    ('<position kp="10" kv="2"/><default class="c"><velocity kv="3"/></default>', '<general class="c"/>'),
    ('<position kp="10" kv="2"/><default class="c"><general gear="2"/></default>', '<velocity class="c"/>'),
    ('<position kp="10" kv="2"/><default class="c"/>', '<velocity class="c"/>'),
    ('<velocity kv="3"/><default class="c"><position kp="20"/></default>', '<general class="c"/>'),
    ('<general gainprm="4" dyntype="filter"/>', '<position/>'),
    ('<general gainprm="4" dyntype="filter"/>', '<velocity/>'),
    ('<position kp="10" kv="2"/><position kp="20"/>', '<position/>'),
    ('<velocity kv="3" ctrlrange="0 1"/><position kp="10"/>', '<velocity/>'),
    ('<position kp="10" timeconst="0.1"/>', '<position/>'),
    ('<general gainprm="5 6 7" gaintype="affine" biasprm="1 2 3 4" biastype="affine"/>', '<velocity/>'),
    ('<general gainprm="5 6 7" gaintype="affine" biasprm="1 -5 -3 4" biastype="affine"/>', '<position/>'),
    ('', '<velocity kp="3"/>'),
    ('', '<motor dampratio="3"/>'),
    ('', '<general kp="3"/>'),
    ('<general gainprm="5 6 7" gaintype="affine" biasprm="1 -5 -3 4" biastype="affine" dyntype="filter" dynprm="0.5 2"/>', '<motor/>'),
    ('<general gainprm="5 6 7" gaintype="affine" biasprm="1 -5 -3 4" biastype="affine" dyntype="filter" dynprm="0.5 2"/>', '<damper ctrlrange="0 1"/>'),
    ('<general gainprm="5"/>', '<general gainprm="7"/>'),
    ('<general gainprm="5 6"/>', '<general biasprm="7"/>'),
    ('<position kp="10" kv="1"/>', '<general gainprm="7"/>'),
    ('', '<general gainprm="7 1" gaintype="affine" biasprm="0 -7 2" biastype="affine"/>'),
    ('', '<general gainprm="0" biasprm="0 0 2" biastype="affine"/>'),
    ('<position kp="10" dampratio="1"/><default class="c"><general biasprm="0 -10 -1"/></default>', '<position class="c"/>'),
    ('<position kp="10" kv="2"/><general ctrlrange="-1 1"/>', '<velocity/>'),
    ('<general ctrlrange="-1 1"/><position kp="10" kv="2"/>', '<velocity/>'),
    ('<position kp="10" kv="2"/><general/>', '<velocity/>'),
    ('<position kp="10" kv="2"/>', '<velocity/>'),
    ('<position kp="10" kv="2"/><general gear="2"/>', '<damper ctrlrange="0 1"/>'),
    ('<damper kv="4" ctrlrange="0 1"/><general/>', '<velocity/>'),
    ('<damper kv="4" ctrlrange="0 1"/><general/>', '<position/>'),
    ('<position kp="10"/><general gaintype="affine"/>', '<velocity/>'),
    ('<general gainprm="5"/><default class="c"><damper kv="1" ctrlrange="0 1"/><general gainprm="7 1 2"/></default>', '<position class="c"/>'),
    ('<default class="c"><damper kv="1" ctrlrange="0 1"/><general gainprm="7 1 2"/></default>', '<position class="c"/>'),
    ('<default class="c"><damper kv="1" ctrlrange="0 1"/><general gainprm="7 1 2"/></default>', '<general class="c"/>'),
    ('<general gainprm="5"/><default class="c"><damper kv="1" ctrlrange="0 1"/><general gainprm="7 1 2"/></default>', '<velocity class="c"/>'),
    ('<general gainprm="5"/><default class="c"><damper kv="1" ctrlrange="0 1"/></default>', '<position class="c"/>'),
    ('<general gainprm="5"/><motor/>', '<position/>'),
    ('<general gainprm="5"/><default class="c"><motor/></default>', '<position class="c"/>'),
]


def _compiles_as_mujoco_or_both_refuse(path, text):
    """Compares SCM's compiled model of `path` with MuJoCo's (activation dynamics included);
    where MuJoCo refuses the file, gives an actuator muscle or user dynamics (which SCM has
    not), or gives it dynamics from a default of a kind SCM does not simulate (a `<muscle>`
    default's reaching a `<general>`), SCM must refuse it, saying where. Returns whether it
    compared."""
    try:
        m = mujoco.MjModel.from_xml_path(str(path))
    except ValueError:
        m = None
    unmodelled = (int(mujoco.mjtDyn.mjDYN_MUSCLE), int(mujoco.mjtDyn.mjDYN_USER))
    other_kind = "<muscle" in text
    if m is None or any(int(d) in unmodelled or (int(d) != 0 and other_kind) for d in m.actuator_dyntype):
        out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
        assert out.returncode != 0, f"MuJoCo refuses or adds dynamics, SCM takes:\n{text}"
        assert f"{path}:" in out.stderr, out.stderr
        return False
    try:
        compare(path)
    except AssertionError as e:
        raise AssertionError(f"{e}\n{text}") from e
    return True


def test_actuator_defaults_compile_as_mujoco_compiles_them(tmp_path):
    """MuJoCo 4 gives a shortcut's gain and bias from a default of its kind or from a
    <general> default whose gain it reads, never from a default of another shortcut, while
    ranges and gear are shared by all kinds; a <general> takes what the defaults left, and
    reads a position servo's positive biasprm[2] as a damping ratio. The cases the rules were
    read from, then 300 files mixing defaults of every kind SCM simulates in three nested
    classes: each compiles as MuJoCo compiles it, or both refuse it (a negative damper kv)."""
    for i, (defaults, act) in enumerate(ACTUATOR_DEFAULTS_CASES):
        path = tmp_path / f"case_{i}.xml"
        text = f"""<mujoco>
  <default>{defaults}</default>
  <worldbody><body><joint name="j" type="slide" range="-1 1"/><geom size=".1" mass="2"/></body></worldbody>
  <actuator>{act.replace("/>", ' joint="j"/>')}</actuator>
</mujoco>
"""
        path.write_text(text)
        _compiles_as_mujoco_or_both_refuse(path, text)
    compared = 0
    for i, text in enumerate(_actuator_defaults_cases(300)):
        path = tmp_path / f"random_{i}.xml"
        path.write_text(text)
        compared += _compiles_as_mujoco_or_both_refuse(path, text)
    assert compared > 250, compared


OPEN_BOX = "".join(f"v {x} {y} {z}\n" for z in (0, 0.2) for y in (0, 0.1) for x in (0, 0.3)) + """f 1 3 4
f 1 4 2
f 1 2 6
f 1 6 5
f 2 4 8
f 2 8 6
f 4 3 7
f 4 7 8
f 3 1 5
f 3 5 7
"""


def test_an_open_mesh_collides_and_weighs_by_its_convex_hull_as_in_mujoco(tmp_path):
    """A box without its lid: MuJoCo collides it by its convex hull, and with
    inertia="convex" weighs it by the hull too; SCM samples and weighs the same hull (the
    compared model has the hull's mass, inertia and mesh frame)."""
    (tmp_path / "open_box.obj").write_text(OPEN_BOX)
    path = tmp_path / "open_mesh.xml"
    path.write_text("""<mujoco>
  <asset><mesh name="tray" file="open_box.obj" inertia="convex"/></asset>
  <worldbody>
    <body name="tray" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom type="mesh" mesh="tray" density="500"/>
    </body>
  </worldbody>
</mujoco>
""")
    compare(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert abs(m.body_mass[1] - 500 * 0.3 * 0.1 * 0.2) < 1e-6 * m.body_mass[1]
    out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert out.returncode == 0 and "convex hull" in out.stdout, out.stdout + out.stderr
    # A vertex that no face uses (the last one) is still a vertex of MuJoCo's hull. (A new
    # file name: MuJoCo caches meshes by file within a process.)
    (tmp_path / "open_box_apex.obj").write_text(OPEN_BOX + "v 0.15 0.05 1.0\n")
    text = path.read_text().replace("open_box.obj", "open_box_apex.obj")
    path.write_text(text)
    compare(path)
    assert mujoco.MjModel.from_xml_path(str(path)).body_mass[1] > 500 * 0.3 * 0.1 * 0.2 * 1.5
    # MuJoCo reduces its hull to maxhullvert vertices; SCM does not, and refuses it.
    path.write_text(text.replace('inertia="convex"', 'inertia="convex" maxhullvert="5"'))
    out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and "maxhullvert" in out.stderr, out.stderr


#: An L-shaped prism (closed, not convex): arms 0.4 long and 0.04 wide, 0.05 thick, whose
#: faces' centroid lies outside it (so MuJoCo's default rule counts some volume twice).
L_PRISM = "".join(f"v {x} {y} {z}\n" for z in (0, 0.05) for x, y in
                  ((0, 0), (0.4, 0), (0.4, 0.04), (0.04, 0.04), (0.04, 0.4), (0, 0.4))) + """\
f 1 3 2
f 1 4 3
f 1 6 4
f 4 6 5
f 7 8 9
f 7 9 10
f 7 10 12
f 10 11 12
f 1 2 8
f 1 8 7
f 2 3 9
f 2 9 8
f 3 4 10
f 3 10 9
f 4 5 11
f 4 11 10
f 5 6 12
f 5 12 11
f 6 1 7
f 6 7 12
"""


def test_meshes_weigh_by_mujocos_default_rule_as_in_mujoco(tmp_path):
    """MuJoCo's default mesh inertia (legacy: pyramids from the faces, each counted positive)
    on a closed non-convex mesh, where it differs from the exact solid, and on the open box,
    which it weighs without a lid; inertia="exact" gives the exact solid of the closed one.
    Mass, centre of mass and inertia as MuJoCo's."""
    (tmp_path / "l_prism.obj").write_text(L_PRISM)
    (tmp_path / "open_tray.obj").write_text(OPEN_BOX)
    path = tmp_path / "legacy.xml"
    text = """<mujoco>
  <asset>
    <mesh name="l" file="l_prism.obj" INERTIA/>
    <mesh name="tray" file="open_tray.obj"/>
  </asset>
  <worldbody>
    <body name="l" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom type="mesh" mesh="l"/>
    </body>
    <body name="tray" pos="1 0 1">
      <freejoint/>
      <geom type="mesh" mesh="tray" density="500"/>
    </body>
  </worldbody>
</mujoco>
"""
    path.write_text(text.replace("INERTIA", ""))
    ours = compare(path)
    exact = 1000 * 0.05 * (0.4 * 0.4 - 0.36 * 0.36)
    legacy = ours["bodies"][1]["mass"]
    assert legacy > 1.01 * exact, (legacy, exact)
    assert not [w for w in ours["warnings"] if "inertia" in w], ours["warnings"]
    path.write_text(text.replace("INERTIA", 'inertia="exact"').replace("l_prism.obj", "l_prism_exact.obj"))
    (tmp_path / "l_prism_exact.obj").write_text(L_PRISM)
    ours = compare(path)
    assert abs(ours["bodies"][1]["mass"] - exact) < 1e-7 * exact  # OBJ coordinates are single precision


def test_meshes_weighed_as_shells_compile_as_mujoco_compiles_them(tmp_path):
    """inertia="shell" (three of MuJoCo Menagerie's robots use it): the surface as a thin shell
    whose mass is the density times the area, on the closed non-convex L prism and on the open
    tray, also with a given mass. Mass, centre of mass and inertia as MuJoCo's."""
    (tmp_path / "l_prism.obj").write_text(L_PRISM)
    (tmp_path / "open_tray.obj").write_text(OPEN_BOX)
    path = tmp_path / "shell.xml"
    path.write_text("""<mujoco>
  <asset>
    <mesh name="l" file="l_prism.obj" inertia="shell"/>
    <mesh name="tray" file="open_tray.obj" inertia="shell" scale="1 2 0.5"/>
  </asset>
  <worldbody>
    <body name="l" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom type="mesh" mesh="l" density="20"/>
    </body>
    <body name="tray" pos="1 0 1">
      <freejoint/>
      <geom type="mesh" mesh="tray" mass="0.3"/>
    </body>
  </worldbody>
</mujoco>
""")
    ours = compare(path)
    # The L prism's area (sides and two faces) times the density.
    area = 2 * (0.4 * 0.4 - 0.36 * 0.36) + 0.05 * (0.4 + 0.04 + 0.36 + 0.36 + 0.04 + 0.4)
    assert abs(ours["bodies"][1]["mass"] - 20 * area) < 1e-6 * 20 * area, (ours["bodies"][1]["mass"], 20 * area)


@pytest.mark.parametrize("fitaabb", ["false", "true"])
def test_primitives_fitted_to_meshes_compile_as_mujoco_compiles_them(tmp_path, fitaabb):
    """A sphere, capsule, cylinder, box or ellipsoid with mesh= is fitted to the mesh (MuJoCo
    Menagerie's ARX L5 and RB-Y1 collide by capsules and spheres fitted to their meshes): on
    the non-convex L prism (principal axes off the mesh's own) and the open tray (scaled), from
    their inertia boxes or, under fitaabb, their bounding boxes, with fitscale, a written size
    (overridden) and the default type (a sphere). Sizes, poses (the shapes' axes either way),
    and the bodies' masses and inertias (the fitted shapes weigh) as MuJoCo's."""
    (tmp_path / "l_prism.obj").write_text(L_PRISM)
    (tmp_path / "open_tray.obj").write_text(OPEN_BOX)
    path = tmp_path / "fit.xml"
    path.write_text(f"""<mujoco>
  <compiler fitaabb="{fitaabb}"/>
  <asset>
    <mesh name="l" file="l_prism.obj"/>
    <mesh name="tray" file="open_tray.obj" scale="1 2 0.5"/>
  </asset>
  <worldbody>
    <body name="l" pos="0 0 1" euler="10 20 30">
      <freejoint/>
      <geom name="sphere" mesh="l"/>
      <geom name="capsule" type="capsule" mesh="l" pos="0.1 0 0"/>
      <geom name="cylinder" type="cylinder" mesh="l" fitscale="1.2"/>
      <geom name="box" type="box" size="0.01 0.01 0.01" mesh="l" euler="0 0 30"/>
      <geom name="ellipsoid" type="ellipsoid" mesh="l"/>
    </body>
    <body name="tray" pos="1 0 1">
      <freejoint/>
      <geom name="tray_box" type="box" mesh="tray"/>
      <geom name="tray_capsule" type="capsule" mesh="tray" density="300"/>
    </body>
  </worldbody>
</mujoco>
""")
    ours = compare(path)
    assert all(g["fitted_to"] for g in ours["geoms"]), ours["geoms"]
    assert not ours["warnings"], ours["warnings"]


def test_meshes_placed_by_refpos_and_refquat_compile_as_mujoco_compiles_them(tmp_path):
    """<mesh refpos refquat> (Shadow's DEX-EE in MuJoCo Menagerie): the file's coordinates taken
    relative to that frame, then scaled; on the L prism (closed, weighed by MuJoCo's default
    rule), the open tray (weighed the same way, from the file) and a box fitted to the prism.
    Masses, inertias, mesh frames and the fitted box as MuJoCo's."""
    (tmp_path / "l_prism.obj").write_text(L_PRISM)
    (tmp_path / "open_tray.obj").write_text(OPEN_BOX)
    path = tmp_path / "ref.xml"
    path.write_text("""<mujoco>
  <asset>
    <mesh name="l" file="l_prism.obj" refpos="0.1 0.2 -0.05" refquat="1 -1 0 0.3" scale="1 1.5 2"/>
    <mesh name="tray" file="open_tray.obj" refquat="0 0 1 1"/>
  </asset>
  <worldbody>
    <body name="l" pos="0 0 1">
      <freejoint/>
      <geom type="mesh" mesh="l"/>
      <geom name="fitted" type="box" mesh="l" mass="0.2"/>
    </body>
    <body name="tray" pos="1 0 1">
      <freejoint/>
      <geom type="mesh" mesh="tray" density="500"/>
    </body>
  </worldbody>
</mujoco>
""")
    # The rotated prism's inertia agrees to 7e-9 relative (masses and centres to 1e-9): as for
    # the fruit fly's meshes below, MuJoCo rebuilds a body's inertia from its iterative
    # eigen-decomposition of the mesh's, which is off its axes here.
    compare(path, inertia_tol=1e-7)


#: Meshes given inline: a hull of vertices without faces (a cube's corners and a point inside,
#: scaled and turned), a tetrahedron with its faces given inward, and one left open (three of
#: its four faces; it collides by its hull and weighs by MuJoCo's rule on the faces it has).
INLINE_MESHES = """<mujoco>
  <asset>
    <mesh name="hull" vertex="0 0 0 1 0 0 0 1 0 1 1 0 0 0 1 1 0 1 0 1 1 1 1 1 0.5 0.5 0.5"
          scale="0.1 0.05 0.2" refquat="1 0.3 0 0.2"/>
    <mesh name="tet" vertex="0 0 0 1 0 0 0 1 0 0 0 1" face="0 1 2 0 3 1 0 2 3 1 3 2"
          scale="0.2 0.2 0.2" refpos="0.1 0 0"/>
    <mesh name="open" vertex="0 0 0 1 0 0 0 1 0 0 0 1" face="0 2 1 0 1 3 0 3 2" scale="0.1 0.1 0.1"
          normal="0 0 1 0 0 1 0 0 1 0 0 1"/>
  </asset>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    <body name="hull" pos="0 0 0.5"><freejoint/><geom type="mesh" mesh="hull"/></body>
    <body name="tet" pos="0.5 0 0.5">
      <freejoint/>
      <geom type="mesh" mesh="tet" density="300"/>
      <geom name="fit" type="sphere" mesh="tet" mass="0.1"/>
    </body>
    <body name="open" pos="1 0 0.5"><freejoint/><geom type="mesh" mesh="open"/></body>
  </worldbody>
</mujoco>
"""


def test_meshes_given_inline_compile_as_mujoco_compiles_them(tmp_path):
    """<mesh vertex face> (MuJoCo's car and Rubik's cube): without faces the mesh is the convex
    hull of its vertices, with faces the surface they make (turned outward, or open and
    colliding by its hull); placed by refpos, refquat and scale as a file's are. Masses,
    inertias, mesh frames and a primitive fitted to one, as MuJoCo compiles them; the scene
    runs, and packs into an FMU without a mesh file."""
    path = tmp_path / "inline.xml"
    path.write_text(INLINE_MESHES)
    compare(path, inertia_tol=1e-7)
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.3"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    check = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert check.returncode == 0 and "mesh hull (given inline)" in check.stdout, check.stdout + check.stderr
    assert "normal (MuJoCo renders with it" in check.stdout + check.stderr
    fmu = tmp_path / "inline.fmu"
    packed = subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], capture_output=True, text=True)
    assert packed.returncode == 0, packed.stderr
    import zipfile
    names = zipfile.ZipFile(fmu).namelist()
    assert not [n for n in names if n.startswith("resources/meshes/")], names


def test_a_mesh_file_of_vertices_alone_is_their_convex_hull(tmp_path):
    """An OBJ file with vertices and no faces (MuJoCo's `plugin/sdf/asset/die.obj`) is, as
    MuJoCo makes it, the convex hull of its vertices: a scaled, rotated box's corners with
    points inside and on its faces weigh as MuJoCo weighs them."""
    corners = [(x, y, z) for x in (-1, 1) for y in (-2, 2) for z in (-0.5, 0.5)]
    inside = [(0.1, 0.2, 0.0), (-0.5, 1.0, 0.2), (1.0, 0.0, 0.0)]
    (tmp_path / "points.obj").write_text("".join(f"v {x} {y} {z}\n" for x, y, z in corners + inside))
    path = tmp_path / "points.xml"
    path.write_text("""<mujoco>
  <asset><mesh name="points" file="points.obj" scale="0.1 0.1 0.1" refquat="1 0.2 0 0.1"/></asset>
  <worldbody>
    <body pos="0 0 1"><freejoint/><geom type="mesh" mesh="points"/></body>
  </worldbody>
</mujoco>
""")
    compare(path, inertia_tol=1e-7)


#: MuJoCo's built-in procedural meshes (the carousel's supersphere bags and supertorus ring,
#: the tactile scene's sensor grids), scaled, with a wedge on a visual geom.
BUILTIN_MESHES = """<mujoco>
  <asset>
    <mesh name="ico0" builtin="sphere" params="0"/>
    <mesh name="ico2" builtin="sphere" params="2" scale=".2 .2 .2"/>
    <mesh name="hemi" builtin="hemisphere" params="3" scale=".1 .2 .3"/>
    <mesh name="bag" builtin="supersphere" params="32 .3 .4" scale=".2 .13 .085"/>
    <mesh name="ring" builtin="supertorus" params="16 .2 .4 1" scale="1.7 1.7 .9"/>
    <mesh name="cone" builtin="cone" params="8 .5" scale=".1 .1 .1"/>
    <mesh name="apex" builtin="cone" params="5 0" scale=".1 .1 .2"/>
    <mesh name="grid" builtin="wedge" params="9 9 45 45 0" scale=".3 .3 .3"/>
  </asset>
  <worldbody>
    <geom type="plane" size="20 20 0.1"/>
    <body name="ico0" pos="0 0 2"><freejoint/><geom type="mesh" mesh="ico0"/></body>
    <body name="ico2" pos="3 0 1"><freejoint/><geom type="mesh" mesh="ico2"/></body>
    <body name="hemi" pos="5 0 1"><freejoint/><geom type="mesh" mesh="hemi"/></body>
    <body name="bag" pos="7 0 1"><freejoint/><geom type="mesh" mesh="bag"/>
      <geom type="mesh" mesh="grid" contype="0" conaffinity="0" mass="0"/></body>
    <body name="ring" pos="10 0 2"><freejoint/><geom type="mesh" mesh="ring"/></body>
    <body name="cone" pos="14 0 1"><freejoint/><geom type="mesh" mesh="cone"/></body>
    <body name="apex" pos="16 0 1"><freejoint/><geom type="mesh" mesh="apex"/></body>
  </worldbody>
</mujoco>
"""


def test_builtin_meshes_compile_as_mujoco_compiles_them(tmp_path):
    """<mesh builtin params> (MuJoCo's carousel and tactile scenes): an icosahedron subdivided
    twice, a hemisphere, a supersphere, a supertorus, a cone and a pointed cone, made vertex for
    vertex in single precision as MuJoCo makes them, weigh as MuJoCo weighs them (masses and
    inertias to rounding: the same triangles); a tactile sensor's wedge on a visual geom is left
    out, listed; the scene runs."""
    path = tmp_path / "builtin.xml"
    path.write_text(BUILTIN_MESHES)
    compare(path, inertia_tol=1e-7)
    check = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    assert check.returncode == 0, check.stderr
    assert "geom left out: its mesh is not a closed surface (MuJoCo's built-in wedge is the point grid of a tactile sensor" in check.stdout + check.stderr
    run = subprocess.run([str(SCM), "simulate", str(path), "--duration", "0.1"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr


@pytest.mark.parametrize("mesh, says", [
    ('<mesh name="m" builtin="sphere" params="5"/>', "subdivision is 0 to 4"),
    ('<mesh name="m" builtin="supertorus" params="16 1.5 1 1"/>', "radius in (0, 1]"),
    ('<mesh name="m" builtin="supersphere" params="16 1"/>', "takes 3 parameter(s)"),
    ('<mesh name="m" builtin="hemisphere" params="11"/>', "0 to 10"),
    ('<mesh name="m" builtin="sphere" params="1" file="x.obj"/>', "not both"),
    ('<mesh name="m" builtin="wedge" params="5 5 200 45 0"/>', "fields of view"),
])
def test_a_builtin_mesh_mujoco_refuses_is_refused_saying_why(tmp_path, mesh, says):
    """Parameters MuJoCo's compiler refuses for a built-in mesh, SCM refuses at the mesh's line."""
    text = f'<mujoco><asset>{mesh}</asset><worldbody><body><freejoint/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>'
    path = tmp_path / "bad.xml"
    path.write_text(text)
    with pytest.raises(ValueError):
        mujoco.MjModel.from_xml_path(str(path))
    out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and says in out.stderr and "bad.xml:1" in out.stderr, out.stderr


def test_a_geom_colliding_by_a_tactile_grid_is_refused(tmp_path):
    """A geom that collides by a tactile sensor's point grid (builtin wedge or plate, which
    have no closed surface) is refused, saying what to do; as a visual geom it is left out."""
    path = tmp_path / "grid.xml"
    path.write_text("""<mujoco><asset><mesh name="m" builtin="plate" params="5 5" scale=".3 .5 .2"/></asset>
  <worldbody><body><freejoint/><geom type="sphere" size="0.1"/><geom type="mesh" mesh="m" mass="0"/></body></worldbody></mujoco>""")
    out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and "point grid of a tactile sensor" in out.stderr and "contype=" in out.stderr, out.stderr


@pytest.mark.parametrize("mesh, says", [
    ('<mesh vertex="0 0 0 1 0 0 0 1 0 0 0 1"/>', "needs a name"),
    ('<mesh name="m" vertex="0 0 0 1 0 0 0 1 0"/>', "at least 4"),
    ('<mesh name="m" vertex="0 0 0 1 0 0 0 1 0 0 0"/>', "not a multiple of 3"),
    ('<mesh name="m" vertex="0 0 0 1 0 0 0 1 0 1 1 0"/>', "convex hull"),
    ('<mesh name="m" vertex="0 0 0 1 0 0 0 1 0 0 0 1" face="0 2 1 0 1 3 0 3 9"/>', "vertex '9'"),
    ('<mesh name="m" face="0 1 2"/>', "give them with vertex"),
])
def test_an_inline_mesh_mujoco_refuses_is_refused_saying_why(tmp_path, mesh, says):
    """What MuJoCo's compiler refuses in an inline mesh, SCM refuses too, at the mesh's line
    and saying what is wrong."""
    text = f'<mujoco><asset>{mesh}</asset><worldbody><body><freejoint/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>'
    path = tmp_path / "bad.xml"
    path.write_text(text)
    with pytest.raises(ValueError):
        mujoco.MjModel.from_xml_path(str(path))
    out = subprocess.run([str(SCM), "compile", str(path)], capture_output=True, text=True)
    assert out.returncode != 0 and says in out.stderr and "bad.xml:1" in out.stderr, out.stderr


def _png(rows):
    """A grey 8-bit PNG of `rows` (lists of 0..255), written here (no imaging package)."""
    import struct
    import zlib
    chunk = lambda kind, data: (struct.pack(">I", len(data)) + kind + data
                                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    header = struct.pack(">IIBBBBB", len(rows[0]), len(rows), 8, 0, 0, 0, 0)
    pixels = b"".join(b"\0" + bytes(r) for r in rows)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(pixels)) + chunk(b"IEND", b"")


HEIGHT_FIELD = """<mujoco>
  <asset>
    <hfield name="pit" nrow="5" ncol="5" size="0.4 0.4 0.1 0.05"
            elevation="3 3 3 3 3  3 3 3 3 3  3 3 1 3 3  3 3 3 3 3  3 3 3 3 3"/>
    FIELD
  </asset>
  <worldbody>
    <geom type="hfield" hfield="pit"/>
    <geom type="hfield" hfield="step" pos="1.5 0 0"/>
    <body name="in_pit" pos="0.01 -0.005 0.15"><freejoint/><geom size="0.03"/></body>
    <body name="on_top" pos="0.3 0.3 0.2"><freejoint/><geom size="0.03"/></body>
    <body name="up" pos="1.5 0.25 0.2"><freejoint/><geom size="0.03"/></body>
    <body name="down" pos="1.5 -0.25 0.2"><freejoint/><geom size="0.03"/></body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("field", ["png", "custom", "inline"])
def test_height_fields_with_elevation_data_collide_as_in_mujoco(tmp_path, field):
    """Height fields with elevation data (inline, written from +y down; a grey PNG, as MuJoCo's
    touch-grid scene; MuJoCo's own binary file), scaled to [0, 1] as MuJoCo scales them. Two balls dropped on a step whose
    high side is the image's top rows (MuJoCo's +y) rest where MuJoCo's do after 1 s, up and
    down, their heights within 1.5 mm (measured 0.9 mm: SCM's ball sinks 1.1 mm into the field's
    cloud where MuJoCo's sinks 0.2 mm, the pair's softness of docs/mjcf.md), and one on the
    inline field's flat top likewise. A ball dropped into the inline field's pit (an
    inverted pyramid cut by MuJoCo's diagonals) ends in it, within 2 mm of the lowest place the
    pit leaves a ball (0.0367 m, off the apex by 4.5 mm along a diagonal, computed here from the
    triangles; MuJoCo's rests there, 0.3 mm deep): SCM's rests on the apex 1.6 mm lower, the
    cloud's concave corner reading shallower than the faces do (an open item). The file packs
    into the FMU."""
    import struct
    step = [[255] * 5, [255] * 5, [0] * 5, [0] * 5]
    if field == "png":
        (tmp_path / "step.png").write_bytes(_png(step))
        asset = '<hfield name="step" file="step.png" size="0.4 0.3 0.1 0.05"/>'
    elif field == "inline":
        # Written from +y down, as an image (MuJoCo reverses the rows it reads).
        elevation = "  ".join(" ".join(str(x) for x in r) for r in step)
        asset = f'<hfield name="step" nrow="4" ncol="5" elevation="{elevation}" size="0.4 0.3 0.1 0.05"/>'
    else:
        rows = step[::-1]  # MuJoCo's file runs from -y
        data = struct.pack("<ii", 4, 5) + struct.pack("<20f", *[x / 255 * 7 + 2 for r in rows for x in r])
        (tmp_path / "step.bin").write_bytes(data)
        asset = '<hfield name="step" file="step.bin" size="0.4 0.3 0.1 0.05"/>'
    path = tmp_path / "fields.xml"
    path.write_text(HEIGHT_FIELD.replace("FIELD", asset))
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    while d.time < 1.0 - 1e-9:
        mujoco.mj_step(m, d)
    csv = tmp_path / "run.csv"
    subprocess.run([str(SCM), "simulate", str(path), "--duration", "1", "--output-interval", "0.5",
                    "-o", str(csv)], check=True, capture_output=True)
    rows = np.genfromtxt(csv, delimiter=",", names=True)
    ours = {name: np.array([rows[f"{name}pos{a}"][-1] for a in "xyz"]) for name in ("in_pit", "on_top", "up", "down")}
    theirs = {name: d.qpos[7 * k:7 * k + 3] for k, name in enumerate(ours)}
    for name in ours:
        print(f"{name}: SCM {ours[name]}, MuJoCo {theirs[name]}")
    for name in ("on_top", "up", "down"):
        # Height within 1.5 mm; sideways within 2 mm: the 3 cm ball's cloud (216 points at
        # 1 cm) rolls onto one of its facets, 1.4 mm on the flat top (measured).
        assert abs(ours[name][2] - theirs[name][2]) < 1.5e-3, (name, ours[name], theirs[name])
        assert np.linalg.norm(ours[name][:2] - theirs[name][:2]) < 2e-3, (name, ours[name], theirs[name])
    # Up on the step and the top (0.1 m + the radius), down at the step's foot.
    assert abs(theirs["up"][2] - 0.13) < 1e-3 and abs(theirs["down"][2] - 0.03) < 1e-3
    lowest = np.array([-0.0045, -0.0045, 0.0367])
    assert np.linalg.norm(theirs["in_pit"] - lowest) < 1e-3
    assert np.linalg.norm(ours["in_pit"] - lowest) < 8e-3 and abs(ours["in_pit"][2] - lowest[2]) < 2e-3
    fmu = tmp_path / "fields.fmu"
    subprocess.run([str(SCM), "pack", str(path), "-o", str(fmu)], check=True, capture_output=True)
    import zipfile
    if field != "inline":
        assert f"resources/meshes/step.{'png' if field == 'png' else 'bin'}" in zipfile.ZipFile(fmu).namelist()


def test_a_flat_height_field_compiles_as_the_plane_of_its_surface(tmp_path):
    """A height field without elevation data (dm_control's quadruped terrain, which its task
    fills at run time) is flat when compiled: SCM takes it as the plane of its surface, here
    raised and tilted, with a warning naming its extent; the rest of the model as MuJoCo's
    (tests/mjcf_compile.rs drops a ball on it)."""
    path = tmp_path / "field.xml"
    path.write_text("""<mujoco>
  <asset>
    <hfield name="terrain" nrow="11" ncol="11" size="3 2 1 0.1"/>
  </asset>
  <worldbody>
    <geom name="ground" type="hfield" hfield="terrain" pos="0 0 0.05" euler="5 0 0"/>
    <body name="ball" pos="0 0 0.3">
      <freejoint/>
      <geom type="sphere" size="0.05"/>
    </body>
  </worldbody>
</mujoco>
""")
    ours = compare(path)
    assert any("height field 'terrain' is flat" in w and "6 x 4 m" in w for w in ours["warnings"]), ours["warnings"]


@pytest.mark.parametrize("case", ["short_13", "short_02", "l_caps"])
def test_obj_polygons_are_split_as_mujoco_splits_them(tmp_path, case):
    """A quad along its shorter diagonal (a pyramid on a bent quad base, each diagonal the
    shorter in turn: the enclosed volume tells the split) and a flat six-corner L-shaped cap by
    clipping ears (its fan from the first corner would reach outside the L): masses and
    inertias as MuJoCo's."""
    if case == "l_caps":
        obj = ("".join(f"v {x} {y} {z}\n" for z in (0, 0.5) for x, y in ((0, 0), (2, 0), (2, 1), (1, 1), (1, 3), (0, 3)))
               + "f 3 2 1 6 5 4\nf 7 8 9 10 11 12\n"
               + "".join(f"f {i} {i % 6 + 1} {i % 6 + 7}\nf {i} {i % 6 + 7} {i + 6}\n" for i in range(1, 7)))
    else:
        far = 1.0 if case == "short_13" else 1.5
        obj = (f"v 0 0 0\nv {far} 0 0\nv 1 1 0.2\nv 0 {far} 0\nv 0.5 0.5 1\n"
               "f 1 4 3 2\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n")
    (tmp_path / f"{case}.obj").write_text(obj)
    path = tmp_path / "poly.xml"
    path.write_text(f"""<mujoco>
  <asset><mesh name="p" file="{case}.obj"/></asset>
  <worldbody><body name="b"><freejoint/><geom type="mesh" mesh="p"/></body></worldbody>
</mujoco>
""")
    # Inertias to 1.6e-8 (masses to 1e-9): MuJoCo rebuilds them from its iterative
    # eigen-decomposition (its pyramid's x and y moments differ by 1e-9 where they are equal).
    ours = compare(path, inertia_tol=1e-7)
    assert not [w for w in ours["warnings"] if "polygons" in w], ours["warnings"]


@pytest.mark.parametrize("split", ["o", "g", "usemtl"])
def test_obj_files_of_several_objects_weigh_as_in_mujoco(tmp_path, split):
    """MuJoCo 4.0.0 reads the faces of an OBJ file's first object only (an o or g line after
    faces starts another; a material change does not): two tetrahedra in one file weigh as one,
    or as both under two materials, in SCM as in MuJoCo."""
    tetra = lambda o: f"v {o} 0 0\nv {o + 1} 0 0\nv {o} 1 0\nv {o} 0 1\n"
    faces = lambda b: "".join(f"f {a + b} {c + b} {d + b}\n" for a, c, d in ((1, 3, 2), (1, 2, 4), (2, 3, 4), (3, 1, 4)))
    (tmp_path / f"two_{split}.obj").write_text(f"{split} first\n{tetra(0)}{faces(0)}{split} second\n{tetra(2)}{faces(4)}")
    path = tmp_path / "two.xml"
    path.write_text(f"""<mujoco>
  <asset><mesh name="two" file="two_{split}.obj"/></asset>
  <worldbody><body name="b"><freejoint/><geom type="mesh" mesh="two"/></body></worldbody>
</mujoco>
""")
    ours = compare(path)
    one = 1000 / 6
    assert (abs(ours["bodies"][1]["mass"] - one) < 1e-9 * one) == (split != "usemtl"), ours["bodies"][1]["mass"]


def test_equality_defaults_and_a_point_mass_inertial_compile_as_mujoco_compiles_them(tmp_path):
    """Two idioms of MuJoCo Menagerie's RB-Y1: an <equality><joint> in a file whose <default>
    gives <joint> attributes (armature, damping: they are not the equality's, which reads the
    class's <equality> defaults only), and an <inertial> with a mass and no inertia (MuJoCo's
    point mass, here on a body welded to its parent)."""
    path = tmp_path / "idioms.xml"
    path.write_text("""<mujoco>
  <default>
    <joint armature="0.1" damping="1"/>
    <equality solref="0.01 1"/>
  </default>
  <worldbody>
    <body name="base" pos="0 0 1">
      <freejoint/>
      <geom type="box" size="0.1 0.1 0.1"/>
      <body name="a" pos="0.2 0 0">
        <joint name="a" axis="0 1 0"/>
        <geom type="capsule" size="0.02" fromto="0 0 0 0.2 0 0"/>
        <body name="tip" pos="0.2 0 0">
          <inertial pos="0.01 0 0" mass="0.5"/>
        </body>
      </body>
      <body name="b" pos="-0.2 0 0">
        <joint name="b" axis="0 1 0"/>
        <geom type="capsule" size="0.02" fromto="0 0 0 -0.2 0 0"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="a" joint2="b" polycoef="0 1 0 0 0"/>
  </equality>
</mujoco>
""")
    ours = compare(path)
    tip = next(b for b in ours["bodies"] if b["name"] == "tip")
    assert tip["mass"] == 0.5 and not any(tip["inertia"]), tip


def test_mujocos_own_msh_meshes_compile_as_mujoco_compiles_them(tmp_path):
    """MuJoCo's binary mesh format (.msh, the fruit fly's): three fruit fly parts (closed and
    open), scaled up to centimetres so that the compared values are not below the comparison's
    absolute floor, each on a free body weighed by MuJoCo's default rule, compiled as MuJoCo
    compiles them (masses, centres of mass, inertias, mesh frames)."""
    from conftest import DM_CONTROL_ROOT
    meshes = [DM_CONTROL_ROOT / "locomotion/walkers/assets/fruitfly_v2" / f
              for f in ("abdomen_5_lower.msh", "haltere_left_body.msh", "coxa_T2_right_body.msh")]
    bodies = []
    for i, mesh in enumerate(meshes):
        # New file names: MuJoCo caches meshes by file name within a process.
        (tmp_path / f"part{i}.msh").write_bytes(mesh.read_bytes())
        bodies.append(f"""<body name="b{i}" pos="{i} 0 1"><freejoint/><geom type="mesh" mesh="m{i}"/></body>""")
    assets = "".join(f'<mesh name="m{i}" file="part{i}.msh" scale="10 10 10"/>' for i in range(len(meshes)))
    path = tmp_path / "msh.xml"
    path.write_text(f"<mujoco><asset>{assets}</asset><worldbody>{''.join(bodies)}</worldbody></mujoco>")
    # The inertias agree to 1.4e-7 relative (measured; masses and centres to 1e-9). Not
    # isolated: MuJoCo finds a mesh's principal axes by an iterative eigen-decomposition and
    # rebuilds the body's inertia from them.
    ours = compare(path, inertia_tol=1e-6)
    assert all(b["mass"] > 0 for b in ours["bodies"][1:])


def mujoco_body_pairs(m):
    """The body pairs MuJoCo's collision filter lets touch, by its rules (contype/conaffinity
    bits, weld bodies, the parent filter, excludes, explicit pairs), where contact can move
    something: none with constraints or contact switched off, none between two bodies that
    do not move (the world, static and mocap bodies)."""
    off = m.opt.disableflags
    if off & int(mujoco.mjtDisableBit.mjDSBL_CONTACT) or off & int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT):
        return set()
    filterparent = not off & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    weld, parent = m.body_weldid, m.body_parentid
    moves = lambda b: m.body_dofnum[weld[b]] > 0 or any(m.body_dofnum[k] > 0 for k in range(m.nbody) if k != b and _ancestor(m, b, k))
    excluded = {(s >> 16, s & 0xFFFF) for s in m.exclude_signature[:m.nexclude]}
    pairs = set()
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            b1, b2 = m.geom_bodyid[g1], m.geom_bodyid[g2]
            w1, w2 = weld[b1], weld[b2]
            if w1 == w2:
                continue
            if filterparent and w1 and w2 and (w1 == weld[parent[w2]] or w2 == weld[parent[w1]]):
                continue
            if not (m.geom_contype[g1] & m.geom_conaffinity[g2] or m.geom_contype[g2] & m.geom_conaffinity[g1]):
                continue
            if (min(b1, b2), max(b1, b2)) in excluded:
                continue
            pairs.add((b1, b2))
    pairs |= {(m.geom_bodyid[a], m.geom_bodyid[b]) for a, b in zip(m.pair_geom1, m.pair_geom2)}
    return {frozenset((int(a), int(b))) for a, b in pairs if moves(a) or moves(b)}


def _ancestor(m, b, k):
    """Whether body k is an ancestor of body b."""
    while b:
        b = m.body_parentid[b]
        if b == k:
            return True
    return False


DM_LOADING = [p for p in DM_CONTROL if dm_id(p) not in DM_CONTROL_REFUSED]
COLLIDING = CORPUS + DM_LOADING + BUNDLED


@pytest.mark.parametrize("path", COLLIDING, ids=[f"gymnasium-{p.stem}" for p in CORPUS]
                         + [f"dm_control-{dm_id(p)}" for p in DM_LOADING] + [f"scene-{p.stem}" for p in BUNDLED])
def test_the_bodies_that_collide_are_those_mujoco_lets_touch(path):
    """SCM's pairs (scm check) against MuJoCo's filter on the same file, bodies by SCM's
    names (in MuJoCo's order; an unnamed body gets a made-up one). SCM gives each of several
    static planes a body of its own named after the geom (`split_static_planes`); those count
    as the world here."""
    m = mujoco.MjModel.from_xml_path(str(path))
    names = [b["name"] for b in compiled(path)["bodies"]]
    assert len(names) == m.nbody
    out = subprocess.run([str(SCM), "check", str(path)], capture_output=True, text=True)
    as_mujoco = lambda b: b if b in names else names[0]
    # "pair A - B: friction ..., stiffness ...": the bodies before the pair's law.
    ours = {frozenset(map(as_mujoco, line[5:].split(": friction ")[0].split(" - ")))
            for line in out.stdout.splitlines() if line.startswith("pair ")}
    theirs = {frozenset(names[b] for b in pair) for pair in mujoco_body_pairs(m)}
    assert ours == theirs, (sorted(map(sorted, ours - theirs)), sorted(map(sorted, theirs - ours)))


REPLICATED = """<mujoco model="replicated">
  <compiler angle="{angle}" eulerseq="{seq}"/>
  <default><default class="stud"><geom type="sphere" size="0.004" mass="0.002"/></default></default>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <replicate count="3" offset="0.1 0 0.05" euler="{e30} 0 {e30}" sep="-">
      <body name="arm" pos="0 0.2 0.1" euler="0 {e30} 0">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom name="link" type="capsule" fromto="0 0 0 0.1 0 0" size="0.01"/>
        <replicate count="12" offset="0 0 0.01" euler="0 0 {e30}" sep="_">
          <frame pos="0.02 0 0">
            <body name="bead"><joint name="slide" type="slide"/><geom type="sphere" size="0.005"/></body>
          </frame>
        </replicate>
      </body>
    </replicate>
    <body name="base">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05"/>
      <replicate count="10" offset="0.02 0 0" childclass="stud">
        <geom name="stud" pos="0 0 0.05"/>
      </replicate>
      <replicate count="0"><body name="never"><geom size="0.01"/></body></replicate>
    </body>
  </worldbody>
  <worldbody>
    <replicate count="4" euler="0 0 {e90}">
      <geom name="wall" type="box" size="0.5 0.02 0.1" pos="0 0.5 0.1"/>
    </replicate>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("angle,seq", [("degree", "xyz"), ("radian", "zyx")])
def test_replicates_expand_as_mujoco_expands_them(tmp_path, angle, seq):
    """<replicate>: copies placed by the accumulated offset and rotation, in the compiler's angle
    unit and sequence, names suffixed with the separator and the copy's number written with as many
    digits as the count has (nested: innermost suffix first), inside the world and inside a body,
    around a frame, in a second <worldbody>, with a childclass, and none for a count of 0: bodies,
    joints and geoms as MuJoCo compiles them."""
    e30, e90 = ("30", "90") if angle == "degree" else (repr(np.pi / 6), repr(np.pi / 2))
    path = tmp_path / "replicated.xml"
    path.write_text(REPLICATED.format(angle=angle, seq=seq, e30=e30, e90=e90))
    ours = compare(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert [b["name"] for b in ours["bodies"]] == [m.body(i).name for i in range(m.nbody)]
    # (SCM names an unnamed joint after its body, for the FMU's variables; MuJoCo leaves it blank.)
    assert [j["name"] for j in ours["joints"]] == [m.joint(i).name or ours["joints"][i]["name"] for i in range(m.njnt)]
    assert [m.joint(i).name for i in range(m.njnt)][-3:] == ["slide_10-2", "slide_11-2", ""]
    named = [g["name"] for i, g in enumerate(ours["geoms"]) if m.geom(i).name]
    assert named == [m.geom(i).name for i in range(m.ngeom) if m.geom(i).name]
    # The world's geoms first, the second <worldbody>'s walls among them.
    assert named[:5] == ["floor"] + [f"wall{i}" for i in range(4)]
    assert named[-10:] == [f"stud{i:02}" for i in range(10)]
    assert len(ours["bodies"]) == 1 + 3 * 13 + 1


REFERRED = """<mujoco model="referred">
  <worldbody>
    <site name="top" pos="0 0 1"/>
    <body name="fixed" pos="0.5 0 0.5"><joint name="free_hinge" axis="0 1 0"/><geom size="0.02" mass="1"/></body>
    <replicate count="2" offset="0.1 0 0" sep="-">
      <site name="anchor" pos="0 0 0.9"/>
      <body name="arm" pos="0 0 0.5">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom name="link" type="capsule" fromto="0 0 0 0 0 -0.1" size="0.01"/>
        <site name="tip" pos="0 0 -0.1"/>
        <site name="free_hinge" pos="0 0 -0.05"/>
        <replicate count="3" offset="0 0.05 0" sep="_">
          <body name="finger" pos="0 0 -0.1"><joint name="knuckle" axis="1 0 0"/><geom size="0.005" mass="0.01"/></body>
        </replicate>
      </body>
    </replicate>
  </worldbody>
  <tendon>
    <spatial name="cord" stiffness="10"><site site="anchor"/><site site="tip"/></spatial>
    <spatial stiffness="5"><site site="top"/><site site="tip"/></spatial>
    <fixed name="pair"><joint joint="hinge" coef="1"/><joint joint="free_hinge" coef="-1"/></fixed>
  </tendon>
  <actuator>
    <motor name="shoulder" joint="hinge" gear="2"/>
    <motor name="plain" joint="free_hinge"/>
    <position name="curl" joint="knuckle" kp="3"/>
    <motor name="pull" tendon="cord" gear="4"/>
  </actuator>
  <actuator>
    <motor name="second" joint="free_hinge" gear="3"/>
  </actuator>
</mujoco>
"""


def test_elements_naming_replicated_ones_are_copied_as_mujoco_copies_them(tmp_path):
    """An actuator on a replicated joint, a tendon through replicated sites (or through one
    replicated site and one outside), a fixed tendon on a replicated and an outside joint, an
    actuator on such a tendon, under nested replicates: MuJoCo copies each with every replica
    (names and references suffixed), after the elements that name nothing replicated, replica by
    replica; SCM compiles the same tendons and actuators in the same order."""
    path = tmp_path / "referred.xml"
    path.write_text(REFERRED)
    ours = compare(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    names = [a.get("name") for a in ours["actuators"]]
    assert names == [m.actuator(i).name or names[i] for i in range(m.nu)]
    # Two <actuator> sections are one list: the copies after both sections' others. The inner
    # replicate moved `curl` after `pull` before the outer one copied them all. `plain` and
    # `second` name the joint `free_hinge`, not the replicated site of that name: not copied.
    assert names[:6] == ["plain", "second", "shoulder-0", "pull-0", "curl_0-0", "curl_1-0"]
    assert ours["actuators"][3]["tendon"] == "cord-0" and ours["actuators"][8]["tendon"] == "cord-1"
    assert len(names) == 2 + 2 * 5




ATTACH_CHILD = """<mujoco model="arm">
  <compiler angle="radian" eulerseq="zyx" meshdir="assets"/>
  <option timestep="0.01" gravity="0 0 -1"/>
  <default>
    <joint damping="0.5" armature="0.01"/>
    <geom size="0.03" density="800" friction="0.6"/>
    <default class="finger"><geom type="capsule" size="0.01 0.04"/><joint range="-0.5 1.2"/></default>
  </default>
  <asset><mesh name="knob" file="knob.obj" scale="0.5 0.5 0.5"/><mesh file="lug.obj"/></asset>
  <worldbody>
    <geom name="table" type="box" size="0.3 0.3 0.02" pos="0 0 -0.1"/>
    <body name="upper" pos="0 0 0.3" euler="0.3 0.2 0.1">
      <joint name="shoulder" axis="0 1 0" range="-1 1" springref="0.2" stiffness="3"/>
      <geom name="upper" type="capsule" fromto="0 0 0 0.2 0 0"/>
      <body name="fore" pos="0.2 0 0">
        <joint name="elbow" axis="0 1 0"/>
        <geom type="mesh" mesh="knob"/>
        <geom type="mesh" mesh="lug" pos="0.05 0 0"/>
        <site name="tip" pos="0.1 0 0"/>
        <body name="finger" childclass="finger" pos="0.1 0 0">
          <joint name="curl" axis="0 0 1"/>
          <geom name="nail"/>
        </body>
      </body>
    </body>
    <body name="left_behind" pos="1 0 0"><joint name="lone"/><geom size="0.05"/></body>
  </worldbody>
  <tendon><fixed name="couple" stiffness="2"><joint joint="shoulder" coef="1"/><joint joint="elbow" coef="-0.5"/></fixed></tendon>
  <equality><joint joint1="curl" joint2="elbow" polycoef="0 0.5 0 0 0"/></equality>
  <contact><exclude body1="upper" body2="finger"/></contact>
  <actuator>
    <motor name="lift" joint="shoulder" gear="2" ctrlrange="-1 1"/>
    <position joint="curl" kp="4"/>
    <motor name="pull" tendon="couple"/>
    <motor name="alone" joint="lone"/>
  </actuator>
  <keyframe><key name="bent" qpos="0.1 0.2 0.3 0.4"/></keyframe>
</mujoco>
"""

ATTACH_PARENT = """<mujoco model="bench">
  <default><joint damping="9" armature="0.2"/><geom size="0.2" friction="0.9"/></default>
  <asset><model name="arm" file="kid/arm.xml"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="cart" pos="0 0 0.5">
      <joint name="rail" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.1 0.1 0.05"/>
      <frame pos="0 0 0.1" euler="0 0 90">
        <attach model="arm" body="upper" prefix="a_"/>
      </frame>
    </body>
    <replicate count="2" offset="0 0.8 0" sep="-">
      <body name="post" pos="-1 -1 0.2"><geom type="box" size="0.05 0.05 0.2"/>
        <attach model="arm" body="fore" prefix="b_"/>
      </body>
    </replicate>
    <body name="shelf" pos="1 1 0.5"><attach model="arm" prefix="c_"/></body>
  </worldbody>
  <actuator><motor name="push" joint="rail"/></actuator>
</mujoco>
"""


def _cube_obj(half):
    v = [(x, y, z) for x in (-half, half) for y in (-half, half) for z in (-half, half)]
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
    return "".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces)


def test_attached_models_compile_as_mujoco_attaches_them(tmp_path):
    """<attach>: a body of another model, grafted inside a frame of a moving body, inside a
    replicate (prefix, then the replicate's suffix), and a whole model's world: the child keeps its
    own defaults (not the parent's), its angle unit and Euler sequence, its meshes (found under its
    own meshdir); its tendons, equalities, exclusions and actuators that name what is attached come
    along, those that name what is left behind do not. Bodies, joints (ranges in the child's unit),
    geoms, tendons, equalities and actuators as MuJoCo compiles them, with MuJoCo's names."""
    (tmp_path / "kid" / "assets").mkdir(parents=True)
    (tmp_path / "kid" / "arm.xml").write_text(ATTACH_CHILD)
    (tmp_path / "kid" / "assets" / "knob.obj").write_text(_cube_obj(0.03))
    (tmp_path / "kid" / "assets" / "lug.obj").write_text(_cube_obj(0.01))
    path = tmp_path / "bench.xml"
    path.write_text(ATTACH_PARENT)
    ours = compare(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert [b["name"] for b in ours["bodies"]] == [m.body(i).name for i in range(m.nbody)]
    assert [j["name"] for j in ours["joints"]] == [m.joint(i).name for i in range(m.njnt)]
    named = [a["name"] for i, a in enumerate(ours["actuators"]) if m.actuator(i).name]
    assert named == [m.actuator(i).name for i in range(m.nu) if m.actuator(i).name]
    assert "a_alone" not in named and "c_alone" in named
    assert [t["name"] for t in ours["tendons"]] == [m.tendon(i).name for i in range(m.ntendon)]
    # The equality inside `fore` comes with every attach; the exclusion of `upper` and `finger`
    # only with those that attach both; the coupling tendon (and its actuator) only with those
    # that attach both its joints: MuJoCo drops the others, and SCM lists them as unused.
    assert m.neq == len(ours["equalities"]) == 4 and m.nexclude == 2
    assert [t["name"] for t in ours["tendons"]] == ["a_couple", "c_couple"]
    dropped = [u for u in ours["unused"] if "leaves behind in model 'arm'" in u]
    assert len(dropped) == 2 * 2, dropped  # the tendon and the exclusion, for each b_ copy
    # The child's own defaults and unit: the shoulder's range is 1 radian, its damping the child's.
    shoulder = next(j for j in ours["joints"] if j["name"] == "a_shoulder")
    assert shoulder["range"] == pytest.approx([-1, 1]) and shoulder["damping"] == 0.5
    # The meshes come once per attach (a replicate's copies share theirs), from the child's meshdir.
    assert {g["mesh"] for g in ours["geoms"] if g["mesh"]} == {
        m.mesh(i).name for i in range(m.nmesh)} == {f"{p}_{n}" for p in "abc" for n in ("knob", "lug")}


SELF_ATTACH = """<mujoco model="belts">
  <default>
    <default class="heavy"><geom density="3000" friction="0.7"/><joint damping="2"/></default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 0.1"/>
    <frame pos="0 -1 0.3" euler="0 0 90">
      <frame name="conveyor">
        <geom name="belt" type="box" size=".7 .3 .05" surfacevel=".5 0 0 0 0 0"/>
        <geom name="rail" type="box" size=".7 .02 .1" pos="0 .33 .04"/>
      </frame>
    </frame>
    <frame pos="1 0 0.6" euler="0 -20 0"><attach frame="conveyor" prefix="up_"/></frame>
    <body name="base" pos="0 1 0.5" childclass="heavy">
      <body name="arm">
        <joint name="swing" axis="0 1 0"/>
        <geom name="link" type="capsule" size=".03" fromto="0 0 0 .3 0 0"/>
      </body>
    </body>
    <body name="stand" pos="1 1 0.5"><attach body="arm" prefix="copy_"/></body>
  </worldbody>
  <actuator><motor name="drive" joint="swing"/></actuator>
</mujoco>
"""


def test_a_part_of_the_same_model_attaches_as_mujoco_attaches_it(tmp_path):
    """<attach> without model= (MuJoCo's self-attachment): a frame of geoms copied under another
    frame (as MuJoCo's luggage carousel builds its conveyors), and a body under another body, which
    keeps the default class it had where it was written (its geoms' density and friction, its
    joint's damping) and brings the actuator on its joint, prefixed. Bodies, joints, geoms and
    actuators as MuJoCo compiles them, with MuJoCo's names."""
    path = tmp_path / "belts.xml"
    path.write_text(SELF_ATTACH)
    ours = compare(path)
    m = mujoco.MjModel.from_xml_path(str(path))
    assert [b["name"] for b in ours["bodies"]] == [m.body(i).name for i in range(m.nbody)]
    assert [g["name"] for g in ours["geoms"]] == [m.geom(i).name for i in range(m.ngeom)]
    assert [j["name"] for j in ours["joints"]] == [m.joint(i).name for i in range(m.njnt)]
    assert [a["name"] for a in ours["actuators"]] == [m.actuator(i).name for i in range(m.nu)]
    assert "up_belt" in [m.geom(i).name for i in range(m.ngeom)]
    copied = next(g for g in ours["geoms"] if g["name"] == "copy_link")
    assert copied["friction"] == 0.7 and copied["surfacevel"] is None
    belt = next(g for g in ours["geoms"] if g["name"] == "up_belt")
    assert belt["surfacevel"] == [0.5, 0, 0, 0, 0, 0]
    assert next(j for j in ours["joints"] if j["name"] == "copy_swing")["damping"] == 2
