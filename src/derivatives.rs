//! Exact first and second derivatives of the whole simulation, from the same generic code that
//! computes the values (num-dual's dual numbers through [`Scalar`]).
//!
//! # What is offered
//! - [`forward_jacobian`]: `∂v̇/∂(q, v, u, p)` of forward dynamics [`Model::forward`], contact
//!   included.
//! - [`step_jacobian`]: `∂(q', v')/∂(q, v, u, p)` of one step of any integrator
//!   ([`Model::step_with`]); for `implicit_euler` the derivative of the converged Newton
//!   solution (the implicit-function derivative), for `dopri5` of one step of fixed length.
//! - [`forward_hessians`]: the Hessian of every component of `v̇` with respect to `(q, v, u, p)`.
//! - [`distance_hessian`]: value, gradient and Hessian of a pair's smooth separation distance `D`
//!   with respect to `(q, ε1, ε2)`.
//! - The generic engines [`jacobian`] and [`hessians`] for any [`VectorFunction`].
//!
//! `u` is the input vector of [`Model::nu`] (actuator controls, then each mocap body's pose and
//! velocity); `p` the seven SCM parameters in [`PARAMS`] order (ε1, ε2, ε3, k, v_d, v_s, μ).
//! The dissipation variant ([`Dissipation`](crate::contact::Dissipation)) is carried along
//! unchanged, so the derivatives are those of the variant the model uses (the C¹ paper variant
//! has second derivatives that jump at `s = 0` and `s = 2`; the C² `smooth` variant has none).
//!
//! # Quaternion coordinates
//! [`Coordinates::Embedded`]: configurations are the `nq` stored numbers, quaternions as their
//! four components. Every function normalizes a quaternion before use, so a derivative is that
//! of the function of the *normalized* quaternion: along the quaternion itself it is zero, and
//! at a unit quaternion the four columns are the derivative in `R⁴` of `f(q/|q|)`. This is what
//! an FMI host sees (`J.quat.w|x|y|z` are plain variables). Output quaternions of a step are the
//! normalized result's components.
//!
//! [`Coordinates::Tangent`]: configurations are perturbed on the group, `q ⊕ δ` with `δ ∈ R^nv`
//! (see [`Tree::integrate_q`](crate::dynamics::Tree::integrate_q)`(q, δ, 1)`: body-frame rotation
//! vectors for quaternions), and output configurations are expressed as `q'_0 ⊖ q'` around the
//! nominal result (see [`Tree::difference_q`](crate::dynamics::Tree::difference_q)). Jacobians are
//! then `2nv × 2nv` in the state block and have no null directions: the form for trajectory
//! optimization and estimation. Hessians in tangent coordinates are those of the function
//! composed with the exponential chart at the point.
//!
//! # How
//! Jacobians are computed in passes of [`DualSVec64`](num_dual::DualSVec64) with up to 8 directions each (so a Jacobian
//! with `n` columns costs `⌈n/8⌉` passes of the vector-dual code); Hessians in blocks of 4×4 with
//! [`HyperDualSVec64`](num_dual::HyperDualSVec64)`<4, 4>` (`⌈n/4⌉(⌈n/4⌉+1)/2` passes). `DualDVec64` (dynamic width) is not
//! `Copy`, so it does not satisfy [`Scalar`]; nested duals do not either. The scalar types that
//! do: `f64`, `Dual64`, `DualSVec64<N>`, `Dual2_64`, `Dual2SVec64<N>`, `HyperDual64`,
//! `HyperDualSVec64<M, N>` (checked by a test).

pub use crate::autodiff::{hessians, jacobian, VectorFunction};
use crate::contact::ContactParams;
use crate::contact::Param;
use crate::dynamics::Tree;
use crate::integrate::{Integrator, State};
use crate::model::{DynamicsError, Model};
use crate::scalar::{c, Scalar};
use nalgebra::{DMatrix, DVector};

/// The SCM parameters that derivatives are taken with respect to, in the order of `p`.
pub const PARAMS: [Param; 7] = Param::ALL;

/// How configurations (and their quaternions) are coordinatized in Jacobians and Hessians (see
/// the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Coordinates {
    /// The `nq` stored numbers; functions of normalized quaternions.
    #[default]
    Embedded,
    /// Perturbations `δ ∈ R^nv` on the group, `q ⊕ δ`; outputs as `q'_0 ⊖ q'`.
    Tangent,
}

/// A point to differentiate at: state, inputs and contact parameters (f64).
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Generalized positions (`nq`).
    pub q: Vec<f64>,
    /// Generalized velocities (`nv`).
    pub v: Vec<f64>,
    /// Inputs (`Model::nu()` of them).
    pub u: Vec<f64>,
    /// Actuator activations (`Model::na()`): held at these values, not differentiated here
    /// (the FMU's directional derivatives take them as states).
    pub act: Vec<f64>,
    /// Contact parameters (their dissipation variant is kept).
    pub params: ContactParams<f64>,
}

impl Point {
    /// The point of a model's start: `q0`, at rest, inputs `u0`, the scene's parameters.
    pub fn start(model: &Model) -> Point {
        Point {
            q: model.tree.q0(),
            v: vec![0.0; model.tree.nv],
            u: model.u0(),
            act: model.act0.clone(),
            params: model.contact,
        }
    }
}

/// Sizes of the variable blocks of `z = [q, v, u, p]` in given coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Configuration block (`nq` embedded, `nv` tangent).
    pub nq: usize,
    /// Velocity block.
    pub nv: usize,
    /// Input block.
    pub nu: usize,
    /// Parameter block (7).
    pub np: usize,
}

impl Layout {
    /// Total number of variables.
    pub fn len(&self) -> usize {
        self.nq + self.nv + self.nu + self.np
    }

    /// Whether there are no variables.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Column ranges of the blocks `q`, `v`, `u`, `p`.
    pub fn ranges(&self) -> [std::ops::Range<usize>; 4] {
        let (a, b, c) = (self.nq, self.nq + self.nv, self.nq + self.nv + self.nu);
        [0..a, a..b, b..c, c..c + self.np]
    }
}

/// Parameters as a vector in [`PARAMS`] order.
pub fn params_vec<T: Copy>(p: &ContactParams<T>) -> Vec<T> {
    PARAMS.iter().map(|k| k.get(p)).collect()
}

/// Parameters from a vector in [`PARAMS`] order, keeping `like`'s clouds' ε1 factors,
/// dissipation variant, dissipation force, margin, adhesion, gap, actuators' pull and moving surfaces (constants).
pub fn params_from<T: Scalar>(x: &[T], like: &ContactParams<f64>) -> ContactParams<T> {
    ContactParams {
        eps1: x[0],
        eps1_scale: like.eps1_scale,
        eps2: x[1],
        eps3: x[2],
        stiffness: x[3],
        dissipation_velocity: x[4],
        stiction_velocity: x[5],
        friction: x[6],
        dissipation_force: c(like.dissipation_force),
        hold_separation: like.hold_separation,
        margin: c(like.margin),
        adhesion: like.adhesion,
        gap: like.gap,
        pull: like.pull.map(c),
        surface: like.surface,
        dissipation: like.dissipation,
    }
}

/// The differentiable variables `z = [q, v, u, p]` of a point and the map back from them.
struct Chart<'a> {
    tree: &'a Tree,
    point: &'a Point,
    coords: Coordinates,
    layout: Layout,
}

impl<'a> Chart<'a> {
    fn new(model: &'a Model, point: &'a Point, coords: Coordinates) -> Self {
        Self::with_params(model, point, coords, true)
    }

    /// A chart whose `z` holds the parameters (`params`) or only `[q, v, u]` (the parameters
    /// are then the point's, constant).
    fn with_params(model: &'a Model, point: &'a Point, coords: Coordinates, params: bool) -> Self {
        let tree = &model.tree;
        let nq = if coords == Coordinates::Embedded {
            tree.nq
        } else {
            tree.nv
        };
        Chart {
            tree,
            point,
            coords,
            layout: Layout {
                nq,
                nv: tree.nv,
                nu: point.u.len(),
                np: if params { PARAMS.len() } else { 0 },
            },
        }
    }

    /// `z` at the point.
    fn z0(&self) -> Vec<f64> {
        let mut z = match self.coords {
            Coordinates::Embedded => self.point.q.clone(),
            Coordinates::Tangent => vec![0.0; self.tree.nv],
        };
        z.extend_from_slice(&self.point.v);
        z.extend_from_slice(&self.point.u);
        if self.layout.np > 0 {
            z.extend(params_vec(&self.point.params));
        }
        z
    }

    /// `(q, v, u, p)` of `z`.
    fn unpack<T: Scalar>(&self, z: &[T]) -> (Vec<T>, Vec<T>, Vec<T>, ContactParams<T>) {
        let [rq, rv, ru, rp] = self.layout.ranges();
        let q = match self.coords {
            Coordinates::Embedded => z[rq].to_vec(),
            Coordinates::Tangent => {
                let q0: Vec<T> = self.point.q.iter().map(|&x| c(x)).collect();
                self.tree.integrate_q(&q0, &z[rq], T::one())
            }
        };
        let p = if self.layout.np > 0 {
            params_from(&z[rp], &self.point.params)
        } else {
            self.point.params.lift()
        };
        (q, z[rv].to_vec(), z[ru].to_vec(), p)
    }
}

/// Forward dynamics as a function of `z`.
struct ForwardFn<'a> {
    model: &'a Model,
    chart: Chart<'a>,
}

impl VectorFunction for ForwardFn<'_> {
    fn eval<T: Scalar>(&self, z: &[T]) -> Result<Vec<T>, DynamicsError> {
        self.model.check_activations(&self.chart.point.act)?;
        let (q, v, u, p) = self.chart.unpack(z);
        let act: Vec<T> = self.chart.point.act.iter().map(|&a| c(a)).collect();
        let u = self.model.driven_inputs(&u, &act, &q, None);
        Ok(self
            .model
            .forward(&q, &v, &u, &p)?
            .vdot
            .iter()
            .copied()
            .collect())
    }
}

/// Jacobian blocks of a vector output with respect to `z = [q, v, u, p]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Jacobian {
    /// The output's value at the point.
    pub value: DVector<f64>,
    /// `∂/∂z`, all blocks side by side (columns in [`Layout::ranges`] order).
    pub full: DMatrix<f64>,
    /// Column layout.
    pub layout: Layout,
}

impl Jacobian {
    fn block(&self, k: usize) -> DMatrix<f64> {
        let r = self.layout.ranges()[k].clone();
        self.full.columns(r.start, r.len()).into_owned()
    }

    /// `∂/∂q` (configuration block, in the chosen coordinates).
    pub fn dq(&self) -> DMatrix<f64> {
        self.block(0)
    }

    /// `∂/∂v`.
    pub fn dv(&self) -> DMatrix<f64> {
        self.block(1)
    }

    /// `∂/∂u` (inputs).
    pub fn du(&self) -> DMatrix<f64> {
        self.block(2)
    }

    /// `∂/∂p` (SCM parameters, [`PARAMS`] order).
    pub fn dp(&self) -> DMatrix<f64> {
        self.block(3)
    }
}

/// `v̇ = FD(q, v, u, p)` and its exact Jacobian with respect to `z = [q, v, u, p]`
/// (`nv × (nq|nv + nv + nu + 7)`).
pub fn forward_jacobian(
    model: &Model,
    point: &Point,
    coords: Coordinates,
) -> Result<Jacobian, DynamicsError> {
    let f = ForwardFn {
        model,
        chart: Chart::new(model, point, coords),
    };
    let (value, full) = jacobian(&f, &f.chart.z0())?;
    Ok(Jacobian {
        value: DVector::from_vec(value),
        full,
        layout: f.chart.layout,
    })
}

/// Second derivatives of a vector output with respect to `z = [q, v, u, p]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Hessians {
    /// The output's value at the point.
    pub value: DVector<f64>,
    /// One symmetric `n_z × n_z` Hessian per output component.
    pub hessians: Vec<DMatrix<f64>>,
    /// Row and column layout of every Hessian.
    pub layout: Layout,
}

/// Hessians of every component of `v̇ = FD(q, v, u, p)` with respect to `z = [q, v, u, p]`: one
/// symmetric `n_z × n_z` matrix per acceleration, with the value.
pub fn forward_hessians(
    model: &Model,
    point: &Point,
    coords: Coordinates,
) -> Result<Hessians, DynamicsError> {
    let f = ForwardFn {
        model,
        chart: Chart::new(model, point, coords),
    };
    let (value, hessians) = hessians(&f, &f.chart.z0())?;
    Ok(Hessians {
        value: DVector::from_vec(value),
        hessians,
        layout: f.chart.layout,
    })
}

/// One integrator step as a function of `z`, with the next state in the chosen coordinates.
struct StepFn<'a> {
    model: &'a Model,
    integrator: Integrator,
    h: f64,
    chart: Chart<'a>,
    /// Nominal next configuration (for tangent outputs).
    q_next: Vec<f64>,
}

impl VectorFunction for StepFn<'_> {
    fn eval<T: Scalar>(&self, z: &[T]) -> Result<Vec<T>, DynamicsError> {
        let (q, v, u, p) = self.chart.unpack(z);
        let act = self.chart.point.act.iter().map(|&a| c(a)).collect();
        let next =
            (self.model).step_with(self.integrator, &State { q, v, act }, &u, &p, c(self.h))?;
        let mut out = match self.chart.coords {
            Coordinates::Embedded => next.q,
            Coordinates::Tangent => {
                let q0: Vec<T> = self.q_next.iter().map(|&x| c(x)).collect();
                self.model.tree.difference_q(&q0, &next.q)
            }
        };
        out.extend(next.v);
        Ok(out)
    }
}

/// One step of `integrator` of length `h` (s) from the point, and the exact Jacobian of the
/// next state `[q', v']` (rows: `nq + nv` embedded, `2 nv` tangent) with respect to
/// `z = [q, v, u, p]`.
pub fn step_jacobian(
    model: &Model,
    integrator: Integrator,
    point: &Point,
    h: f64,
    coords: Coordinates,
) -> Result<(State<f64>, Jacobian), DynamicsError> {
    let next = model.step_with(
        integrator,
        &State {
            q: point.q.clone(),
            v: point.v.clone(),
            act: point.act.clone(),
        },
        &point.u,
        &point.params,
        h,
    )?;
    let f = StepFn {
        model,
        integrator,
        h,
        chart: Chart::new(model, point, coords),
        q_next: next.q.clone(),
    };
    let (value, full) = jacobian(&f, &f.chart.z0())?;
    Ok((
        next,
        Jacobian {
            value: DVector::from_vec(value),
            full,
            layout: f.chart.layout,
        },
    ))
}

/// [`step_jacobian`] with respect to the state and inputs only, `z = [q, v, u]` (the
/// parameters are the point's, held constant; the layout's parameter block is empty): the
/// Jacobian a trajectory optimizer or an estimator needs at every step.
pub fn step_jacobian_state(
    model: &Model,
    integrator: Integrator,
    point: &Point,
    h: f64,
    coords: Coordinates,
) -> Result<(State<f64>, Jacobian), DynamicsError> {
    let next = model.step_with(
        integrator,
        &State {
            q: point.q.clone(),
            v: point.v.clone(),
            act: point.act.clone(),
        },
        &point.u,
        &point.params,
        h,
    )?;
    let f = StepFn {
        model,
        integrator,
        h,
        chart: Chart::with_params(model, point, coords, false),
        q_next: next.q.clone(),
    };
    let (value, full) = jacobian(&f, &f.chart.z0())?;
    Ok((
        next,
        Jacobian {
            value: DVector::from_vec(value),
            full,
            layout: f.chart.layout,
        },
    ))
}

/// The smooth separation distance of one pair as a function of `[q, ε1, ε2]`.
struct DistanceFn<'a> {
    model: &'a Model,
    pair: usize,
    chart: Chart<'a>,
}

impl VectorFunction for DistanceFn<'_> {
    fn eval<T: Scalar>(&self, z: &[T]) -> Result<Vec<T>, DynamicsError> {
        let nq = self.chart.layout.nq;
        let mut full: Vec<T> = self.chart.z0().iter().map(|&x| c(x)).collect();
        full[..nq].copy_from_slice(&z[..nq]);
        let [_, _, _, rp] = self.chart.layout.ranges();
        full[rp.start] = z[nq];
        full[rp.start + 1] = z[nq + 1];
        let (q, v, u, p) = self.chart.unpack(&full);
        let (_, mocap) = self.model.split_inputs(&u)?;
        let kin = self.model.tree.kinematics_with(&q, &v, mocap);
        let pr = &self.model.pairs[self.pair];
        let (Some(a), Some(b)) = (&self.model.colliders[pr.a], &self.model.colliders[pr.b]) else {
            return Ok(vec![c(f64::INFINITY)]);
        };
        let field = crate::collision::separation_field(
            a,
            &kin.frames[pr.a],
            b,
            &kin.frames[pr.b],
            pr.eps1_sides(p.eps1),
        );
        Ok(vec![
            crate::collision::SeparationDistribution::new(&field, p.eps2).distance,
        ])
    }
}

/// Value, gradient and Hessian of the smooth separation distance `D` of pair `pair` (index
/// into `Model::pairs`) with respect to `[q, ε1, ε2]` (configuration in the chosen coordinates).
pub fn distance_hessian(
    model: &Model,
    pair: usize,
    point: &Point,
    coords: Coordinates,
) -> Result<(f64, DVector<f64>, DMatrix<f64>), DynamicsError> {
    let f = DistanceFn {
        model,
        pair,
        chart: Chart::new(model, point, coords),
    };
    let z0 = f.chart.z0();
    let nq = f.chart.layout.nq;
    let mut x = z0[..nq].to_vec();
    let rp = f.chart.layout.ranges()[3].start;
    x.extend_from_slice(&[z0[rp], z0[rp + 1]]);
    let (value, h) = hessians(&f, &x)?;
    let (_, g) = jacobian(&f, &x)?;
    Ok((
        value[0],
        g.row(0).transpose(),
        h.into_iter().next().unwrap_or_else(|| DMatrix::zeros(0, 0)),
    ))
}
