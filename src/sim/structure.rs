//! `<ModelStructure>` of a scene's FMU: which knowns (states, inputs, parameters) each unknown
//! (output, state derivative) depends on, derived from the structure of the model (which joints
//! move which body, which bodies share a mass matrix block, which bodies form a contact pair,
//! which actuator drives which joint), never "depends on everything".
//!
//! The dependencies are structural: a listed known may have a zero partial derivative at some
//! states (e.g. a contact force with respect to a velocity when the bodies are apart), but a
//! known that is not listed has a zero partial derivative at every state. Tests check the
//! second statement against the exact directional derivatives.

use std::collections::BTreeSet;

use super::{Param, Slot};
use crate::collision::Collider;
use crate::dynamics::JointKind;
use crate::fmi::contract::{Causality, Initial, ModelStructure, VarType, Variable};
use crate::model::{ActivationLaw, Model, Transmission};

/// A set of knowns, by what they are (not yet by value reference).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Knowns {
    /// Position coordinates `q[i]`.
    pub q: BTreeSet<usize>,
    /// Velocity coordinates `v[i]`.
    pub v: BTreeSet<usize>,
    /// Actuator controls.
    pub ctrl: BTreeSet<usize>,
    /// Activations.
    pub act: BTreeSet<usize>,
    /// Mocap inputs `(mocap body, component)` (components 0-2 position, 3-6 quaternion). They act
    /// at once in Model Exchange only; in Co-Simulation their partials are zero (a listed
    /// dependency may be zero), since an input there is the pose reached at the end of the next
    /// communication step.
    pub mocap: BTreeSet<(usize, usize)>,
    /// Contact parameters (knowns of `<InitialUnknowns>` only: FMI 2.0 does not list
    /// parameters as knowns of outputs and derivatives).
    pub params: BTreeSet<usize>,
}

impl Knowns {
    fn union(&mut self, other: &Knowns) {
        self.q.extend(&other.q);
        self.v.extend(&other.v);
        self.ctrl.extend(&other.ctrl);
        self.act.extend(&other.act);
        self.mocap.extend(&other.mocap);
        self.params.extend(&other.params);
    }

    /// Whether the known in `slot` is in the set.
    pub fn contains(&self, slot: Slot) -> bool {
        match slot {
            Slot::Q(i) => self.q.contains(&i),
            Slot::V(i) => self.v.contains(&i),
            Slot::Ctrl(i) => self.ctrl.contains(&i),
            Slot::Act(k) => self.act.contains(&k),
            Slot::Mocap(m, k) => self.mocap.contains(&(m, k)),
            Slot::Param(p) => self.params.contains(&param_index(p)),
            _ => false,
        }
    }
}

fn param_index(p: Param) -> usize {
    Param::ALL.iter().position(|&x| x == p).unwrap_or(0)
}

/// Joints on the path from body `b` to the world.
fn path_joints(model: &Model, b: usize) -> Vec<usize> {
    model.tree.path_joints(b)
}

/// The body right below the world on the path of `b` (the root of its subtree; its mass
/// matrix block is shared by every body of the subtree).
fn subtree_root(model: &Model, mut b: usize) -> usize {
    while let Some(p) = model.tree.bodies[b].parent {
        if p == 0 {
            return b;
        }
        b = p;
    }
    b
}

/// Position and velocity coordinates of `joints`.
fn coordinates(model: &Model, joints: &[usize], with_v: bool) -> Knowns {
    let mut k = Knowns::default();
    for &j in joints {
        let jt = &model.tree.joints[j];
        k.q.extend(jt.qadr..jt.qadr + jt.kind.nq());
        if with_v {
            k.v.extend(jt.dadr..jt.dadr + jt.kind.nv());
        }
    }
    k
}

/// What the contact outputs of pair `p` depend on: the poses (and for forces, the velocities)
/// of both bodies, and the contact parameters the quantity uses.
fn pair_knowns(model: &Model, p: usize, distance_only: bool) -> Knowns {
    let pair = &model.pairs[p];
    let (Some(ca), Some(cb)) = (&model.colliders[pair.a], &model.colliders[pair.b]) else {
        // Without two colliders the pair's outputs are constant (no contact).
        return Knowns::default();
    };
    let mut joints = path_joints(model, pair.a);
    joints.extend(path_joints(model, pair.b));
    let mut k = coordinates(model, &joints, !distance_only);
    // An adhesion actuator on either body pulls the pair: its forces read its control (or
    // its activation).
    let mut activation = 0;
    for (a, act) in model.actuators.iter().enumerate() {
        let pulls = matches!(act.target, Transmission::Body(b) if b == pair.a || b == pair.b);
        if pulls && !distance_only {
            match act.activation {
                Some(_) => k.act.insert(activation),
                None => k.ctrl.insert(a),
            };
        }
        activation += usize::from(act.activation.is_some());
    }
    for body in [pair.a, pair.b] {
        if let Some(m) = model.tree.mocap.iter().position(|&b| b == body) {
            k.mocap.extend((0..7).map(|c| (m, c)));
        }
    }
    // The smooth separation distance uses the separation distribution (ε2) and, when a point
    // cloud's planes are queried (two point clouds; a half-space's SSDF is exact), the SSDF (ε1);
    // the forces use the other contact parameters too.
    let both_clouds = matches!((ca, cb), (Collider::Aopc(_), Collider::Aopc(_)));
    let used: Vec<Param> = Param::ALL
        .into_iter()
        .filter(|&p| {
            (p != Param::Eps1 || both_clouds)
                && !pair.owns(p)
                && (!distance_only || matches!(p, Param::Eps1 | Param::Eps2))
        })
        .collect();
    k.params = used.into_iter().map(param_index).collect();
    k
}

/// What the accelerations of the subtree rooted at `root` depend on: its own coordinates (mass
/// matrix, bias and passive forces), the controls of actuators on its joints, and every contact
/// pair one of whose bodies is in the subtree.
fn subtree_knowns(model: &Model, root: usize) -> Knowns {
    let tree = &model.tree;
    let joints: Vec<usize> = (0..tree.joints.len())
        .filter(|&j| subtree_root(model, tree.joints[j].body) == root)
        .collect();
    let mut k = coordinates(model, &joints, true);
    // An actuator's force reads its control, or its activation where it has one (a PID's
    // integral: both, and its length's coordinates).
    let mut activation = 0;
    for (a, act) in model.actuators.iter().enumerate() {
        let drives = (model.actuator_joints(act).iter()).any(|j| joints.contains(j));
        if drives {
            match act.activation.map(|d| d.law) {
                Some(ActivationLaw::PidIntegral { .. }) => {
                    k.act.insert(activation);
                    k.ctrl.insert(a);
                    k.union(&coordinates(model, &model.actuator_joints(act), false));
                }
                Some(_) => {
                    k.act.insert(activation);
                }
                None => {
                    k.ctrl.insert(a);
                }
            }
        }
        activation += usize::from(act.activation.is_some());
    }
    if joints.iter().any(|&j| tree.joints[j].frictionloss > 0.0) {
        k.params.insert(param_index(Param::StictionVelocity));
    }
    for (p, pair) in model.pairs.iter().enumerate() {
        let involved = [pair.a, pair.b]
            .iter()
            .any(|&b| b != 0 && tree.body_moves(b) && subtree_root(model, b) == root);
        if involved {
            k.union(&pair_knowns(model, p, false));
        }
    }
    k
}

/// What the accelerations of the subtree rooted at `root` depend on: its own knowns
/// ([`subtree_knowns`]) and those of every subtree a tendon that exerts force (or that an
/// actuator drives) or an equality constraint ties to it
/// (directly or through other tendons), since the tendon's force on each of its joints
/// depends on all of them.
fn coupled_knowns(model: &Model, root: usize) -> Knowns {
    let tree = &model.tree;
    let root_of_dof = |d: usize| {
        let j = tree
            .joints
            .iter()
            .find(|j| (j.dadr..j.dadr + j.kind.nv()).contains(&d))
            .expect("a tendon's dof belongs to a joint");
        subtree_root(model, j.body)
    };
    let mut roots: BTreeSet<usize> = [root].into();
    let mut friction = false;
    loop {
        let before = roots.len();
        let actuated = |t: usize| {
            model
                .actuators
                .iter()
                .any(|a| a.target == Transmission::Tendon(t))
        };
        for (_, t) in (model.tendons.iter().enumerate()).filter(|(i, t)| t.acts() || actuated(*i)) {
            let tied: Vec<usize> = t.joints.iter().map(|&(_, d, _)| root_of_dof(d)).collect();
            if tied.iter().any(|r| roots.contains(r)) {
                roots.extend(tied);
                friction |= t.frictionloss > 0.0;
            }
        }
        let moving_roots = |bodies: &mut dyn Iterator<Item = usize>| -> Vec<usize> {
            bodies
                .filter(|&b| b != 0 && tree.body_moves(b))
                .map(|b| subtree_root(model, b))
                .collect()
        };
        for c in &model.connects {
            let tied = moving_roots(&mut [c.first.0, c.second.0].into_iter());
            if tied.iter().any(|r| roots.contains(r)) {
                roots.extend(tied);
            }
        }
        let actuated_spatial =
            |t: usize| (model.actuators.iter()).any(|a| a.target == Transmission::Spatial(t));
        for (_, t) in (model.spatial_tendons.iter().enumerate())
            .filter(|(i, t)| t.law.acts() || actuated_spatial(*i))
        {
            let tied = moving_roots(&mut t.bodies());
            if tied.iter().any(|r| roots.contains(r)) {
                roots.extend(tied);
                friction |= t.law.frictionloss > 0.0;
            }
        }
        // A slider-crank's force on each of its two bodies depends on both.
        for a in &model.actuators {
            if let crate::model::Transmission::SliderCrank(k) = a.target {
                let crank = &model.slider_cranks[k];
                let tied = moving_roots(&mut [crank.crank.1, crank.slider.1].into_iter());
                if tied.iter().any(|r| roots.contains(r)) {
                    roots.extend(tied);
                }
            }
        }
        for e in &model.equalities {
            let tied: Vec<usize> = e.dofs().map(root_of_dof).collect();
            if tied.iter().any(|r| roots.contains(r)) {
                roots.extend(tied);
            }
        }
        if roots.len() == before {
            break;
        }
    }
    let mut k = Knowns::default();
    // A connect or a spatial tendon that pulls on a mocap body makes the accelerations of what
    // it ties depend on that body's inputs.
    let links = (model.connects.iter().map(|c| vec![c.first.0, c.second.0])).chain(
        (model.spatial_tendons.iter())
            .filter(|t| t.law.acts())
            .map(|t| t.bodies().collect()),
    );
    for bodies in links {
        let tied = bodies
            .iter()
            .any(|&b| b != 0 && tree.body_moves(b) && roots.contains(&subtree_root(model, b)));
        for &b in bodies.iter().filter(|_| tied) {
            if let Some(m) = tree.mocap.iter().position(|&x| x == b) {
                k.mocap.extend((0..7).map(|c| (m, c)));
            }
        }
    }
    for r in roots {
        k.union(&subtree_knowns(model, r));
    }
    if friction {
        k.params.insert(param_index(Param::StictionVelocity));
    }
    k
}

/// The knowns an unknown in `slot` depends on; `None` if the slot is not an unknown (inputs,
/// parameters, time, solver settings).
pub fn knowns_of(model: &Model, slot: Slot) -> Option<Knowns> {
    let tree = &model.tree;
    let joint_of_v = |i: usize| {
        tree.joints
            .iter()
            .find(|j| (j.dadr..j.dadr + j.kind.nv()).contains(&i))
    };
    let joint_of_q = |i: usize| {
        tree.joints
            .iter()
            .find(|j| (j.qadr..j.qadr + j.kind.nq()).contains(&i))
    };
    Some(match slot {
        // A state as an output is the state itself.
        Slot::Q(i) => Knowns {
            q: [i].into(),
            ..Knowns::default()
        },
        Slot::V(i) => Knowns {
            v: [i].into(),
            ..Knowns::default()
        },
        Slot::Act(k) => Knowns {
            act: [k].into(),
            ..Knowns::default()
        },
        // An activation's rate reads its actuator's control, and the activation itself
        // unless it integrates the control; a PID's integral reads the actuator's length too.
        Slot::ActDot(k) => {
            let (a, d) = (model.actuators.iter().enumerate())
                .filter_map(|(a, x)| x.activation.map(|d| (a, d)))
                .nth(k)?;
            let own = Knowns {
                ctrl: [a].into(),
                act: match d.law {
                    ActivationLaw::Integrator => BTreeSet::new(),
                    _ => [k].into(),
                },
                ..Knowns::default()
            };
            match d.law {
                ActivationLaw::PidIntegral { .. } => {
                    let mut k =
                        coordinates(model, &model.actuator_joints(&model.actuators[a]), false);
                    k.union(&own);
                    k
                }
                _ => own,
            }
        }
        Slot::QDot(i) => {
            let j = joint_of_q(i)?;
            let quat = match j.kind {
                JointKind::Free if i >= j.qadr + 3 => Some((j.qadr + 3, j.dadr + 3)),
                JointKind::Ball => Some((j.qadr, j.dadr)),
                _ => None,
            };
            match quat {
                // q̇ = ½ q ⊗ (0, ω): each component is bilinear in the other three quaternion
                // components and the three angular velocity components.
                Some((qa, wa)) => Knowns {
                    q: (qa..qa + 4).filter(|&c| c != i).collect(),
                    v: (wa..wa + 3).collect(),
                    ..Knowns::default()
                },
                // Positions: q̇ is the matching velocity (free joints: linvel, world frame).
                None => Knowns {
                    v: [j.dadr + (i - j.qadr)].into(),
                    ..Knowns::default()
                },
            }
        }
        Slot::VDot(i) => coupled_knowns(model, subtree_root(model, joint_of_v(i)?.body)),
        Slot::PairForce(p, _) | Slot::PairTorque(p, _) => pair_knowns(model, p, false),
        // A limit's force depends on its joint's coordinate and velocity alone.
        Slot::LimitForce(j) => {
            let jt = &model.tree.joints[j];
            Knowns {
                q: [jt.qadr].into(),
                v: [jt.dadr].into(),
                ..Knowns::default()
            }
        }
        // A tendon limit's force depends on the coordinates and velocities of its joints.
        // A spatial tendon's limit force depends on the poses and velocities of the bodies of
        // its sites, wrapping geoms and side sites (and a mocap body's inputs).
        Slot::SpatialTendonLimitForce(t) => {
            let tendon = &model.spatial_tendons[t];
            let bodies: BTreeSet<usize> = tendon.bodies().collect();
            let joints: Vec<usize> = bodies.iter().flat_map(|&b| path_joints(model, b)).collect();
            let mut k = coordinates(model, &joints, true);
            for b in bodies {
                if let Some(m) = tree.mocap.iter().position(|&x| x == b) {
                    k.mocap.extend((0..7).map(|c| (m, c)));
                }
            }
            k
        }
        Slot::TendonLimitForce(t) => Knowns {
            q: model.tendons[t]
                .joints
                .iter()
                .map(|&(qi, _, _)| qi)
                .collect(),
            v: model.tendons[t]
                .joints
                .iter()
                .map(|&(_, vi, _)| vi)
                .collect(),
            ..Knowns::default()
        },
        // The smooth distance and the soft top-K contact points both come from the separation
        // distribution alone: positions, ε1 (two point clouds) and ε2.
        Slot::PairDistance(p) | Slot::PairPoint(p, _, _) => pair_knowns(model, p, true),
        _ => return None,
    })
}

/// `<ModelStructure>` of the variable table `rows` of `model`: every output, every state
/// derivative (in the order of the continuous states), and the initial unknowns (calculated
/// outputs and the state derivatives), each with its exact dependencies.
pub fn model_structure(model: &Model, rows: &[(Variable, Slot)]) -> ModelStructure {
    // Each slot's first row, by hash: a scene of thousands of pairs has hundreds of thousands
    // of rows, and a search per dependency made this quadratic (minutes for 22 humanoids).
    let mut first: std::collections::HashMap<Slot, u32> =
        std::collections::HashMap::with_capacity(rows.len());
    for (v, s) in rows {
        first.entry(*s).or_insert(v.value_reference);
    }
    let vr_of = |slot: Slot| first.get(&slot).copied();
    let to_vrs = |k: &Knowns, with_params: bool| -> Vec<u32> {
        let mut out: Vec<u32> = Vec::new();
        out.extend(k.q.iter().filter_map(|&i| vr_of(Slot::Q(i))));
        out.extend(k.v.iter().filter_map(|&i| vr_of(Slot::V(i))));
        out.extend(k.ctrl.iter().filter_map(|&i| vr_of(Slot::Ctrl(i))));
        out.extend(k.act.iter().filter_map(|&i| vr_of(Slot::Act(i))));
        out.extend(
            k.mocap
                .iter()
                .filter_map(|&(m, c)| vr_of(Slot::Mocap(m, c))),
        );
        if with_params {
            out.extend(
                k.params
                    .iter()
                    .filter_map(|&i| vr_of(Slot::Param(Param::ALL[i]))),
            );
        }
        out.sort_unstable();
        out
    };
    let mut structure = ModelStructure::default();
    // The accelerations of one subtree share their knowns: each subtree's are gathered once
    // (they scan every pair, and a scene of many bodies has many of both), and listed once as
    // value references, without and with the parameters (300 free leaves that can all touch:
    // 1,800 accelerations of 3,600 knowns each).
    let mut by_root: std::collections::HashMap<usize, (Vec<u32>, Vec<u32>)> =
        std::collections::HashMap::new();
    for (v, slot) in rows {
        let (deps, with_params) = match *slot {
            Slot::VDot(i) => {
                let Some(j) = (model.tree.joints.iter())
                    .find(|j| (j.dadr..j.dadr + j.kind.nv()).contains(&i))
                else {
                    continue;
                };
                let root = subtree_root(model, j.body);
                by_root
                    .entry(root)
                    .or_insert_with(|| {
                        let k = coupled_knowns(model, root);
                        (to_vrs(&k, false), to_vrs(&k, true))
                    })
                    .clone()
            }
            _ => match knowns_of(model, *slot) {
                Some(k) => (to_vrs(&k, false), to_vrs(&k, true)),
                None => continue,
            },
        };
        if v.causality == Causality::Output {
            structure
                .outputs
                .push((v.value_reference, Some(deps.clone())));
        }
        let is_derivative = matches!(
            v.var_type,
            VarType::Real {
                derivative: Some(_),
                ..
            }
        );
        if is_derivative {
            structure.derivatives.push((v.value_reference, Some(deps)));
        }
        // Initial unknowns: everything computed from the exact start values (states,
        // inputs, parameters).
        let calculated = v.initial.unwrap_or(Initial::Calculated) == Initial::Calculated;
        if calculated && (v.causality == Causality::Output || is_derivative) {
            structure
                .initial_unknowns
                .push((v.value_reference, Some(with_params)));
        }
    }
    structure
}
