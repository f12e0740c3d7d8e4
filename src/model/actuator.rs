//! Actuators: what an actuator drives (a joint, a fixed or a spatial tendon, a site), its force law (MuJoCo's
//! motor, position, velocity and affine `<general>` actuators) and the generalized forces of
//! the controls.

use super::{Activation, Model};
use crate::scalar::{c, Scalar};
use nalgebra::DVector;

/// How an actuator turns its control into a joint force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ActuatorKind {
    /// `force = u`.
    Motor,
    /// `force = kp (u - gear·q) - kv gear·v`.
    Position {
        /// Position gain (N/m or N·m/rad).
        kp: f64,
        /// Velocity gain (N·s/m or N·m·s/rad).
        kv: f64,
    },
    /// `force = kv (u - gear·v)`.
    Velocity {
        /// Velocity gain.
        kv: f64,
    },
    /// MuJoCo's `<general>` without activation: `force = (g₀ + g₁ L + g₂ L̇) u + b₀ + b₁ L +
    /// b₂ L̇`, with the actuator's length `L = gear·q` and velocity `L̇ = gear·v` (`gaintype` and
    /// `biastype` `fixed`/`none` leave the terms past `g₀` and `b` zero).
    General {
        /// Gain `g₀ g₁ g₂` (MuJoCo's `gainprm`).
        gain: [f64; 3],
        /// Bias `b₀ b₁ b₂` (MuJoCo's `biasprm`).
        bias: [f64; 3],
    },
}

impl Model {
    /// What actuator `a` drives, for people: `joint NAME` or `tendon NAME`.
    pub fn actuator_target(&self, a: &Actuator) -> String {
        match a.target {
            Transmission::Joint(j) => format!("joint {}", self.tree.joints[j].name),
            Transmission::Tendon(t) => format!("tendon {}", self.tendons[t].name),
            Transmission::Spatial(t) => format!("tendon {}", self.spatial_tendons[t].name),
            Transmission::Site(k) => format!("site {}", self.site_transmissions[k].name),
            Transmission::SliderCrank(k) => {
                let sc = &self.slider_cranks[k];
                format!("slider-crank {} / {}", sc.crank.0, sc.slider.0)
            }
            Transmission::Body(b) => format!("body {}", self.tree.bodies[b].name),
        }
    }

    /// The joints (by index) whose forces actuator `a` sets.
    pub fn actuator_joints(&self, a: &Actuator) -> Vec<usize> {
        match a.target {
            Transmission::Joint(j) => vec![j],
            Transmission::Tendon(t) => self.tendons[t]
                .joints
                .iter()
                .filter_map(|&(_, d, _)| self.tree.joints.iter().position(|j| j.dadr == d))
                .collect(),
            Transmission::Spatial(t) => {
                let mut joints: Vec<usize> = (self.spatial_tendons[t].bodies())
                    .flat_map(|b| self.tree.path_joints(b))
                    .collect();
                joints.sort_unstable();
                joints.dedup();
                joints
            }
            Transmission::Site(k) => self.tree.path_joints(self.site_transmissions[k].body),
            Transmission::SliderCrank(k) => {
                let sc = &self.slider_cranks[k];
                let mut joints = self.tree.path_joints(sc.crank.1);
                joints.extend(self.tree.path_joints(sc.slider.1));
                joints.sort_unstable();
                joints.dedup();
                joints
            }
            // Its own; the pairs it pulls move their other bodies' joints too (their
            // dependencies: `crate::sim`'s model structure).
            Transmission::Body(b) => self.tree.path_joints(b),
        }
    }
}

/// An actuator's site transmission (MuJoCo's `site=` without `refsite`): the force `F` acts at
/// the site as the wrench `F R g_f` (force) and `F R g_t` (torque), `R` the site's frame in the
/// world and `g = (g_f, g_t)` the 6-vector gear; its length is zero and its velocity the
/// moment `Jᵀ (R g_f, R g_t)` times the velocities (the site's velocity along `R g_f` plus the
/// body's angular velocity along `R g_t`), as MuJoCo's transmission makes them.
#[derive(Clone, Debug, PartialEq)]
pub struct SiteTransmission {
    /// The site's name.
    pub name: String,
    /// The site's body.
    pub body: usize,
    /// The site's position in its body's frame.
    pub pos: nalgebra::Vector3<f64>,
    /// The site's orientation in its body's frame.
    pub rotation: nalgebra::Matrix3<f64>,
    /// The gear: force along, then torque about, the site's axes.
    pub gear: [f64; 6],
}

impl SiteTransmission {
    /// The transmission's velocity (its moment times the velocities) at the site's body's
    /// frame; zero on a body without degrees of freedom (`moves` false).
    pub fn velocity<T: Scalar>(&self, frame: &crate::collision::Frame<T>, moves: bool) -> T {
        self.at(frame, moves).3
    }

    /// The force and torque directions in the world, the site's point, its arm from the body
    /// origin, and the transmission's velocity, at the body's frame.
    #[allow(clippy::type_complexity)]
    fn at<T: Scalar>(
        &self,
        frame: &crate::collision::Frame<T>,
        moves: bool,
    ) -> (
        nalgebra::Vector3<T>,
        nalgebra::Vector3<T>,
        nalgebra::Vector3<T>,
        T,
    ) {
        let r = frame.rotation * self.rotation.map(c::<T>);
        let g = self.gear.map(c::<T>);
        let force = r * nalgebra::Vector3::new(g[0], g[1], g[2]);
        let torque = r * nalgebra::Vector3::new(g[3], g[4], g[5]);
        let arm = frame.rotation * self.pos.map(c::<T>);
        // A body without degrees of freedom (the world, a mocap body) has a zero moment.
        let velocity = if moves {
            force.dot(&(frame.linvel + frame.angvel.cross(&arm))) + torque.dot(&frame.angvel)
        } else {
            T::zero()
        };
        (force, torque, arm, velocity)
    }
}

/// MuJoCo's slider-crank transmission: a rod of length `r` joins the crank site `c` to a point
/// that slides along the slider site `s`'s z axis `a`. With `v = c - s`, its length is
/// `L = a·v - √det`, `det = (a·v)² + r² - v·v` (the slider's position along its axis); where
/// `det ≤ 0` the rod cannot reach (MuJoCo's "broken crank") and `L = a·v`, as in MuJoCo. Its
/// moment is `∂L/∂v` at both sites and `∂L/∂a` turning the slider's axis.
#[derive(Clone, Debug, PartialEq)]
pub struct SliderCrank {
    /// The crank site's name, its body and position in that body's frame.
    pub crank: (String, usize, nalgebra::Vector3<f64>),
    /// The slider site's name, its body, position and orientation in that body's frame.
    pub slider: (
        String,
        usize,
        nalgebra::Vector3<f64>,
        nalgebra::Matrix3<f64>,
    ),
    /// The rod's length `r` (`cranklength`).
    pub rod: f64,
}

/// A slider-crank's length, its derivatives with respect to `v = c - s` and to the axis `a`,
/// and the geometry they were taken at.
struct CrankGeometry<T: Scalar> {
    length: T,
    dl_dv: nalgebra::Vector3<T>,
    dl_da: nalgebra::Vector3<T>,
    axis: nalgebra::Vector3<T>,
    /// The sites' arms from their bodies' origins (world axes): crank, slider.
    arms: [nalgebra::Vector3<T>; 2],
}

impl SliderCrank {
    fn geometry<T: Scalar>(&self, frames: &[crate::collision::Frame<T>]) -> CrankGeometry<T> {
        let (fc, fs) = (&frames[self.crank.1], &frames[self.slider.1]);
        let arm_c = fc.rotation * self.crank.2.map(c::<T>);
        let arm_s = fs.rotation * self.slider.2.map(c::<T>);
        let axis = fs.rotation * self.slider.3.column(2).map(c::<T>);
        let v = (fc.origin + arm_c) - (fs.origin + arm_s);
        let av = axis.dot(&v);
        let det = av * av + c::<T>(self.rod * self.rod) - v.dot(&v);
        let (length, dl_dv, dl_da) = if det.re() <= 0.0 {
            (av, axis, v)
        } else {
            let sdet = det.sqrt();
            let k = T::one() - av / sdet;
            (av - sdet, axis * k + v / sdet, v * k)
        };
        CrankGeometry {
            length,
            dl_dv,
            dl_da,
            axis,
            arms: [arm_c, arm_s],
        }
    }

    /// The transmission's length and its rate (the moment times the velocities); `moves`:
    /// whether the crank's and the slider's bodies have degrees of freedom (a body without
    /// any, the world or a mocap body, adds nothing to the rate, as in MuJoCo).
    pub fn length_and_rate<T: Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
        moves: (bool, bool),
    ) -> (T, T) {
        let g = self.geometry(frames);
        let point_velocity = |f: &crate::collision::Frame<T>, arm: &nalgebra::Vector3<T>, moves| {
            if moves {
                f.linvel + f.angvel.cross(arm)
            } else {
                nalgebra::Vector3::zeros()
            }
        };
        let (fc, fs) = (&frames[self.crank.1], &frames[self.slider.1]);
        let dv = point_velocity(fc, &g.arms[0], moves.0) - point_velocity(fs, &g.arms[1], moves.1);
        let turn = match moves.1 {
            true => g.dl_da.dot(&fs.angvel.cross(&g.axis)),
            false => T::zero(),
        };
        (g.length, g.dl_dv.dot(&dv) + turn)
    }

    /// Adds the wrenches of a force `f` along the transmission: `f ∂L/∂v` at the crank site,
    /// its opposite at the slider site, and the torque `f a × ∂L/∂a` on the slider's body.
    pub fn add_force_wrenches<T: Scalar>(
        &self,
        frames: &[crate::collision::Frame<T>],
        f: T,
        w: &mut [crate::contact::Wrench<T>],
    ) {
        let g = self.geometry(frames);
        let force = g.dl_dv * f;
        w[self.crank.1].force += force;
        w[self.crank.1].torque += g.arms[0].cross(&force);
        w[self.slider.1].force -= force;
        w[self.slider.1].torque -= g.arms[1].cross(&force);
        w[self.slider.1].torque += g.axis.cross(&g.dl_da) * f;
    }
}

impl ActuatorKind {
    /// MuJoCo's `gainprm` and `biasprm` (their first three entries) for this actuator: every
    /// kind is the affine law of [`ActuatorKind::General`] with these parameters.
    pub fn gain_bias(&self) -> ([f64; 3], [f64; 3]) {
        match *self {
            ActuatorKind::Motor => ([1.0, 0.0, 0.0], [0.0; 3]),
            ActuatorKind::Position { kp, kv } => ([kp, 0.0, 0.0], [0.0, -kp, -kv]),
            ActuatorKind::Velocity { kv } => ([kv, 0.0, 0.0], [0.0, 0.0, -kv]),
            ActuatorKind::General { gain, bias } => (gain, bias),
        }
    }
}

/// What an actuator drives (MuJoCo's transmission).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Transmission {
    /// A slide or hinge joint (by index): its length is `gear · q`.
    Joint(usize),
    /// A fixed tendon (by index into [`Model::tendons`]): its length is `gear · L`, and the
    /// force acts on each of the tendon's joints through its coefficient.
    Tendon(usize),
    /// A spatial tendon (by index into [`Model::spatial_tendons`]): its length is `gear · L(q)`,
    /// and the force `gear · F` acts along the tendon at its sites, `Jᵀ` of it on the joints.
    Spatial(usize),
    /// A site (by index into [`Model::site_transmissions`], which holds its 6-vector gear; the
    /// actuator's scalar gear is 1): see [`SiteTransmission`].
    Site(usize),
    /// A slider-crank (by index into [`Model::slider_cranks`]): its length is `gear · L(q)`,
    /// see [`SliderCrank`].
    SliderCrank(usize),
    /// A body (by index; MuJoCo's body transmission, which its `<adhesion>` actuator uses): its
    /// length is 0, the gear is not read, and the force pulls the body's pairs together within
    /// their gap ([`Model::pulls`], docs/method.md, departure 9).
    Body(usize),
}

/// An actuator on a 1-DOF joint or a fixed tendon. The generalized force is `gear · force`
/// (times the tendon's coefficients for a tendon).
#[derive(Clone, Debug, PartialEq)]
pub struct Actuator {
    /// Name (the FMU input is `<name>.ctrl`).
    pub name: String,
    /// Kind and gains.
    pub kind: ActuatorKind,
    /// The joint or tendon it drives.
    pub target: Transmission,
    /// Gear ratio.
    pub gear: f64,
    /// Control range, if limited (controls are clamped to it).
    pub ctrlrange: Option<(f64, f64)>,
    /// Force range, if limited (the force is clamped to it, as MuJoCo clamps it; the
    /// derivatives of a clamped force are zero).
    pub forcerange: Option<(f64, f64)>,
    /// Its activation state, if it has one (MuJoCo's `dyntype`): the force law then reads the
    /// activation where it reads the control ([`Model::driven_inputs`]).
    pub activation: Option<Activation>,
}

impl Actuator {
    /// The actuator's force for its input `u` (the clamped control, or the activation) at
    /// joint or tendon position `qj` and rate `vj` (the gear not yet applied), clamped to its
    /// force range.
    pub fn force<T: Scalar>(&self, u: T, qj: T, vj: T) -> T {
        let force = match self.kind {
            ActuatorKind::Motor => u,
            ActuatorKind::Position { kp, kv } => (u - qj * self.gear) * kp - vj * (kv * self.gear),
            ActuatorKind::Velocity { kv } => (u - vj * self.gear) * kv,
            ActuatorKind::General { gain, bias } => {
                let (l, ldot) = (qj * self.gear, vj * self.gear);
                (l * gain[1] + ldot * gain[2] + gain[0]) * u
                    + l * bias[1]
                    + ldot * bias[2]
                    + bias[0]
            }
        };
        match self.forcerange {
            Some((lo, _)) if force.re() < lo => c(lo),
            Some((_, hi)) if force.re() > hi => c(hi),
            _ => force,
        }
    }

    /// The control as the force law reads it: the activation where the actuator has one
    /// ([`Model::driven_inputs`]), else the control clamped to its range.
    fn input<T: Scalar>(&self, u: T) -> T {
        match self.activation {
            Some(_) => u,
            None => self.clamped_control(u),
        }
    }

    /// A control clamped to the control range (the derivative beyond it is zero).
    pub fn clamped_control<T: Scalar>(&self, u: T) -> T {
        match self.ctrlrange {
            Some((lo, _)) if u.re() < lo => c(lo),
            Some((_, hi)) if u.re() > hi => c(hi),
            _ => u,
        }
    }
}

impl Model {
    /// Generalized actuator forces for controls `ctrl` (clamped to their ranges: the derivative
    /// with respect to a clamped control is zero; for an actuator with an activation, its entry
    /// is the activation, not clamped: [`Model::driven_inputs`]), each force clamped to its actuator's
    /// `forcerange`, then the total on a joint with an actuator force range clamped to it (as
    /// MuJoCo clamps `qfrc_actuator`; its derivatives beyond the range are zero).
    ///
    /// Mocap bodies are at their scene poses, at rest: [`Model::actuator_forces_at`] takes
    /// their inputs (they matter to an actuator on a spatial tendon through a mocap body's site).
    pub fn actuator_forces<T: Scalar>(&self, q: &[T], v: &[T], ctrl: &[T]) -> DVector<T> {
        self.actuator_forces_at(q, v, ctrl, &[])
    }

    /// [`Model::actuator_forces`] with the mocap bodies' inputs `mocap` (or empty).
    pub fn actuator_forces_at<T: Scalar>(
        &self,
        q: &[T],
        v: &[T],
        ctrl: &[T],
        mocap: &[T],
    ) -> DVector<T> {
        let mut tau: DVector<T> = DVector::zeros(self.tree.nv);
        // Actuators on spatial tendons: their lengths from the kinematics, their forces as
        // point forces at the sites, turned into generalized forces once for all of them.
        let spatial = (self.actuators.iter())
            .any(|a| {
                matches!(
                    a.target,
                    Transmission::Spatial(_) | Transmission::Site(_) | Transmission::SliderCrank(_)
                )
            })
            .then(|| self.tree.kinematics_with(q, v, mocap));
        // Per-body wrenches only where the kinematics were needed (the check is a pass over the
        // actuators: `actuators` is public, so no flag fixed at load could be trusted).
        let mut wrenches = match spatial {
            Some(_) => vec![crate::contact::Wrench::zero(); self.tree.bodies.len()],
            None => Vec::new(),
        };
        for (a, &u) in self.actuators.iter().zip(ctrl) {
            let u = a.input(u);
            let (qj, vj) = match a.target {
                Transmission::Joint(j) => {
                    let j = &self.tree.joints[j];
                    (q[j.qadr], v[j.dadr])
                }
                Transmission::Tendon(t) => {
                    let t = &self.tendons[t];
                    (t.length(q), t.velocity(v))
                }
                Transmission::Spatial(t) => {
                    let kin = spatial.as_ref().expect("kinematics for spatial tendons");
                    self.spatial_tendons[t].length_and_rate(&kin.frames)
                }
                Transmission::Site(k) => {
                    let kin = spatial.as_ref().expect("kinematics for sites");
                    let site = &self.site_transmissions[k];
                    let moves =
                        self.tree.body_moves(site.body) && !self.tree.bodies[site.body].mocap;
                    (T::zero(), site.at(&kin.frames[site.body], moves).3)
                }
                Transmission::SliderCrank(k) => {
                    let kin = spatial.as_ref().expect("kinematics for slider-cranks");
                    let crank = &self.slider_cranks[k];
                    let moves = |b: usize| self.tree.body_moves(b) && !self.tree.bodies[b].mocap;
                    crank
                        .length_and_rate(&kin.frames, (moves(crank.crank.1), moves(crank.slider.1)))
                }
                // Its force acts through the contacts ([`Model::pulls`]).
                Transmission::Body(_) => continue,
            };
            let force = a.force(u, qj, vj);
            match a.target {
                Transmission::Joint(j) => tau[self.tree.joints[j].dadr] += force * a.gear,
                Transmission::Tendon(t) => {
                    for &(_, vi, coef) in &self.tendons[t].joints {
                        tau[vi] += force * (a.gear * coef);
                    }
                }
                Transmission::Spatial(t) => {
                    let kin = spatial.as_ref().expect("kinematics for spatial tendons");
                    let tendon = &self.spatial_tendons[t];
                    tendon.add_force_wrenches(&kin.frames, force * a.gear, &mut wrenches);
                }
                Transmission::Site(k) => {
                    let kin = spatial.as_ref().expect("kinematics for sites");
                    let site = &self.site_transmissions[k];
                    let (f, t, arm, _) = site.at(&kin.frames[site.body], true);
                    let w = &mut wrenches[site.body];
                    let f = f * (force * a.gear);
                    w.force += f;
                    w.torque += arm.cross(&f) + t * (force * a.gear);
                }
                Transmission::SliderCrank(k) => {
                    let kin = spatial.as_ref().expect("kinematics for slider-cranks");
                    let crank = &self.slider_cranks[k];
                    crank.add_force_wrenches(&kin.frames, force * a.gear, &mut wrenches);
                }
                Transmission::Body(_) => unreachable!("passed over above"),
            }
        }
        if let Some(kin) = &spatial {
            tau += self.tree.wrench_forces(kin, &wrenches);
        }
        for &(d, lo, hi) in &self.actuator_ranges {
            if tau[d].re() < lo {
                tau[d] = c(lo);
            } else if tau[d].re() > hi {
                tau[d] = c(hi);
            }
        }
        tau
    }

    /// The pull of the adhesion actuators ([`Transmission::Body`]) on each body for the inputs
    /// `ctrl` (as [`Model::actuator_forces`] reads them): `None` for a body no such actuator
    /// drives, the sum of their forces for one they drive; empty where the model has none.
    /// MuJoCo applies the force as the average of the normal Jacobians of the body's contacts
    /// (within their gap), minus: a total pull of the force spread over its contacts; SCM pulls
    /// each of the body's pairs within their gap with it (docs/method.md, departure 9).
    pub fn pulls<T: Scalar>(&self, ctrl: &[T]) -> Vec<Option<T>> {
        if !self.has_adhesion() {
            return Vec::new();
        }
        let mut pulls = vec![None; self.tree.bodies.len()];
        for (a, &u) in self.actuators.iter().zip(ctrl) {
            if let Transmission::Body(b) = a.target {
                let f = a.force(a.input(u), T::zero(), T::zero());
                pulls[b] = Some(pulls[b].map_or(f, |p: T| p + f));
            }
        }
        pulls
    }

    /// Whether an adhesion actuator ([`Transmission::Body`]) pulls a body: the contacts then
    /// read the controls ([`Model::pulls`]).
    pub fn has_adhesion(&self) -> bool {
        (self.actuators.iter()).any(|a| matches!(a.target, Transmission::Body(_)))
    }
}
