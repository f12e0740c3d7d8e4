//! How a soft constraint acts under each integrator ([`LimitLaw`], re-exported by
//! [`crate::dynamics::limit`]): MuJoCo's statics, its impedance as an added inertia, or its
//! reference gains, for a joint's limit, a tendon's limit or an equality ([`Held`]).

use crate::integrator::Integrator;

/// How a limit acts (docs/mjcf.md, "Joint limits"). MuJoCo's limit is a soft constraint:
/// with impedance `d` a limited coordinate of effective inertia `I` moves as
/// `r̈ = (1 - d) a - d B ṙ - d² K r`, `a` its acceleration without the limit. Multiplied by
/// `I / (1 - d)`, that is a coordinate of inertia `I / (1 - d)` under the load `I a`, held by
/// a spring and damper `d / (1 - d)` times MuJoCo's reference ones (the [`LimitLaw::Statics`]
/// gains at `d = dmax`): the limit is a spring-damper whose gains give MuJoCo's statics plus an
/// inertia `d / (1 - d) I` on the coordinate while it pushes. In joint space that inertia is
/// `Jᵀ R⁻¹ J` added to the mass matrix, `R` MuJoCo's regularizer, and the forward dynamics with
/// it are MuJoCo's constraint force `(A + R)⁻¹ (a_ref - J a)` exactly (Woodbury's identity).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitLaw {
    /// MuJoCo's reference spring and damper: its dynamics, `1 - dmax` of its statics.
    Reference,
    /// Both gains raised by
    /// [`JointLimit::statics`](crate::dynamics::limit::JointLimit::statics): MuJoCo's statics,
    /// overdamped (its fast mode near `2 / ((1 - dmax) τ)`): for steps that take the limit's
    /// damping implicitly.
    Statics,
    /// The raised gains and MuJoCo's impedance as an added inertia where the limit pushes:
    /// MuJoCo's statics and its dynamics (fast mode `1/τ`), for any step.
    Impedance,
}

impl LimitLaw {
    /// How a constraint of kind `held` acts under `integrator`:
    /// - a joint's limit under implicit and damped Euler: [`LimitLaw::Statics`] (both take the
    ///   limit's damping implicitly, damped Euler's diagonal `D` included); under the others
    ///   [`LimitLaw::Impedance`], its added inertia a diagonal entry of the mass matrix;
    /// - a tendon's limit and an equality: [`LimitLaw::Impedance`] under every integrator;
    ///   under damped Euler a tendon's limit's damping is also taken implicitly along its row
    ///   (`h b Jᵀ J`, `Model::coupled_at`), as a joint's limit's is in `D`: with it explicit, a
    ///   pendulum falling onto a tendon's limit under MuJoCo's Euler gained 4.4 mJ of 3.8 J in
    ///   one step of 2 ms, which the guard refused. (The raised gains alone, as a joint's limit
    ///   has them under damped Euler, overdamp the limit: the second arm of
    ///   tests/fixtures/coupled.xml was 0.031 rad from MuJoCo's at 0.75 s, against 0.004.)
    ///
    /// A tendon's or an equality's added inertia (or implicit damping) is a row across the
    /// tree's branches, taken into the tree's factor ([`crate::dynamics::CoupledFactor`]).
    /// Implicit Euler could take the raised gains alone, but the added inertia gives MuJoCo's
    /// pace as well: on tests/fixtures/coupled.xml under MuJoCo's `implicitfast` the second arm
    /// is at 0.1440 rad at 1 s with it, 0.1541 without, MuJoCo 0.1422 (docs/mjcf.md, "Equality
    /// constraints").
    pub fn under(integrator: Integrator, held: Held) -> LimitLaw {
        use Integrator::{DampedEuler, ImplicitEuler};
        match (integrator, held) {
            (ImplicitEuler | DampedEuler, Held::Joint) => LimitLaw::Statics,
            _ => LimitLaw::Impedance,
        }
    }
}

/// What a soft constraint holds ([`LimitLaw::under`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Held {
    /// A joint's coordinate in its range.
    Joint,
    /// A tendon's length in its range.
    Tendon,
    /// An equality's error at zero.
    Equality,
}
