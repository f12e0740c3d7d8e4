//! The integration methods by name, and the state they advance ([`crate::integrate`] steps
//! them). A leaf: the model names its integrator without depending on the stepping code.

/// Integration method of the internal steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Integrator {
    /// Explicit Euler, as in the paper: `q' = q ⊕ h v`, `v' = v + h v̇(q, v)`. First order;
    /// grows the energy of every oscillation.
    Euler,
    /// Semi-implicit (symplectic) Euler: `v' = v + h v̇(q, v)`, `q' = q ⊕ h v'`. First order,
    /// no energy drift on conservative systems; stable for `h ω < 2` (ω: the stiffest
    /// frequency, `sqrt(k/m)` in contact). MuJoCo's `Euler`.
    #[default]
    SemiImplicitEuler,
    /// Classic fourth-order Runge–Kutta. Stable for `h ω ≲ 2.8`; energy error `O(h⁴)`. MuJoCo's
    /// `RK4` without its constraint solver: MJCF's `RK4` maps to [`Integrator::DampedRk4`].
    Rk4,
    /// MuJoCo's `Euler`: semi-implicit Euler with the joints' viscous damping taken implicitly,
    /// `(M + h D) v̇ = f(q, v)`, `v' = v + h v̇`, `q' = q ⊕ h v'`, where `D` holds each degree of
    /// freedom's joint damping and `f` every force (the damping's `-D v` included). A damped
    /// joint stays stable at any step; without damping it is `semi_implicit_euler`. Where a
    /// joint has frictionloss, `D` also holds the slope `F v_s² / (v_s² + v²)^{3/2}` of SCM's
    /// smooth dry friction `-F v / sqrt(v_s² + v²)` (a damper as stiff as `F / v_s` near rest):
    /// MuJoCo solves frictionloss as a constraint, implicitly, and so takes it at any step;
    /// with the slope implicit, SCM does too (linearly implicit Euler on that term). A joint
    /// limit's damping joins `D` where the limit pushes, and the limit then has MuJoCo's
    /// statics, 20 times its reference stiffness at the default `solimplimit` (docs/mjcf.md,
    /// "Joint limits").
    ///
    /// The contact forces are taken at the end velocity `v'` (the step's equation in `v'`
    /// solved by Newton's iterations when a pair is in reach): their damping and friction, a
    /// damper `μ F / v_s` near rest, are velocity-implicit, as MuJoCo's constraint solver
    /// makes its contact. Without it, a stiff position actuator pressing a light finger on a
    /// block at MuJoCo's 2 ms step blows up (`h μ F / (v_s m)` in the tens). Contact-free and
    /// off its limits, the step is MuJoCo's `Euler` exactly. MJCF's `integrator="Euler"` maps to it (to
    /// `semi_implicit_euler` with `<flag eulerdamp="disable">`).
    DampedEuler,
    /// Classic fourth-order Runge–Kutta whose every stage takes its acceleration as damped
    /// Euler does over the whole step, `(V - v)/h` with `V = v + h (M + h D)⁻¹ f(q, V)` in the
    /// contact's velocities (each stage's contact terms recorded at its positions and replayed
    /// at its trial velocities): the joints' frictionloss and the contact's damping and
    /// friction act implicitly in velocity at every stage, as MuJoCo's
    /// constraint solver makes them at each of its RK4's stages; the joints' viscous damping
    /// stays explicit, a passive force in MuJoCo's RK4. A stage's acceleration then decays a
    /// velocity at a rate of at most `1/h`, which RK4 carries (`h λ < 2.79`), however stiff the
    /// friction at low slip or the damping of a deep overlap: the friction keeps its own
    /// stiction velocity (no floor) and the contact the implicit integrators' bounded damping,
    /// a separation held (docs/method.md, departure 4). The joints' limits act
    /// with MuJoCo's statics and its impedance as an added inertia, which moves them at
    /// MuJoCo's pace, explicitly, as under `rk4`
    /// ([`crate::dynamics::limit::LimitLaw::under`]). Where nothing damps (contact-free, off
    /// the limits, no frictionloss) every stage is the forward dynamics and the step is
    /// classic RK4 to rounding; in contact the damping's implicit part costs an error of order
    /// `h` in those forces, as in damped Euler. MJCF's `integrator="RK4"` maps to it: what
    /// that changes on the contact-on comparison, and what it costs, is measured in
    /// docs/dynamics.md.
    DampedRk4,
    /// Implicit (backward) Euler: `v' = v + h v̇(q', v')`, `q' = q ⊕ h v'`, its step equation in
    /// `v'` solved by Newton iterations on the exact Jacobian from dual numbers. MuJoCo's
    /// `implicit` and `implicitfast` (implicit in velocity) map to it.
    ///
    /// Why this method: contact is stiff (`k` up to 1e9 N/m, so `ω = sqrt(k/m)` reaches 3e4
    /// rad/s for 1 kg) and steps go up to 50 ms, so `h ω` reaches 1e3.
    /// - Explicit methods are unstable there. Implicit midpoint and the trapezoidal rule are
    ///   A-stable, but their amplification tends to -1 for stiff modes, which then ring for ever
    ///   instead of settling. Implicit Euler is **L-stable** (`R(∞) = 0`): unresolved contact
    ///   vibrations die within a step and the state lands on the quasi-static equilibrium, which
    ///   is the physical answer at that step size.
    /// - It takes **impacts without creating energy or penetrating**. Contact starting within a
    ///   step is where higher-order implicit methods fail. Measured over 40 drops of a 1 kg
    ///   sphere (k = 1e6 and 1e9 N/m, h = 8 to 50 ms, drops of 1 to 30 mm while sliding at
    ///   0.1 m/s; energy after each step against the energy before the impact, and the deepest
    ///   end-of-step position below the resting one): implicit Euler ≤ 0.99 of the energy, 38 µm;
    ///   2-stage Radau IIA (order 3, B-stable) ≤ 1.0 but ends impact steps up to 10.7 mm deep,
    ///   because its last stage's force does not move its last position (`(A²)_22 = 0`); the
    ///   L-stable SDIRK of order 2 (γ = 1 - 1/√2) gains 29 % and 2.4 mm, with γ = 1 + 1/√2 5.7 %;
    ///   TR-BDF2 20-fold; Lobatto IIIC found a spurious stage solution with a 1e12-fold gain.
    /// - Energy of resolved motion: first order, it damps an oscillation at `hω = y` by
    ///   `1/(1 + y²)` in energy per step (a pendulum at `hω = 0.01` loses 1e-4 of its energy per
    ///   step). That is the price of the above; `rk4` or `dopri5` keep the energy of resolved
    ///   motion, and a smaller step shrinks the damping quadratically.
    /// - One Newton system of size `nv`; its Jacobian is kept from step to step while the
    ///   iterations contract fast (at rest one Jacobian serves many steps). When contact starts
    ///   within a step far longer than the contact's period, Newton's iterations may fail from
    ///   the contact-free guess: [`Model::advance`](crate::model::Model::advance) then does that step as two halves,
    ///   recursively.
    ImplicitEuler,
    /// Adaptive explicit Dormand–Prince 5(4) with local error control: a step is accepted when
    /// the embedded error estimate is below `solver.tolerance` (absolute plus relative, RMS over
    /// the state), the next step size follows the usual `0.9 err^(-1/5)` controller;
    /// `solver.step` is the first and largest internal step. Stiff contact makes it take small
    /// steps rather than diverge.
    Dopri5,
}

impl Integrator {
    /// Every integrator.
    pub const ALL: [Integrator; 7] = [
        Integrator::Euler,
        Integrator::SemiImplicitEuler,
        Integrator::DampedEuler,
        Integrator::Rk4,
        Integrator::DampedRk4,
        Integrator::ImplicitEuler,
        Integrator::Dopri5,
    ];

    /// Name used in scenes (`scm_integrator`), the command line and the FMU.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Euler => "euler",
            Integrator::SemiImplicitEuler => "semi_implicit_euler",
            Integrator::DampedEuler => "damped_euler",
            Integrator::Rk4 => "rk4",
            Integrator::DampedRk4 => "damped_rk4",
            Integrator::ImplicitEuler => "implicit_euler",
            Integrator::Dopri5 => "dopri5",
        }
    }

    /// Parses a name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }

    /// Whether the method is explicit (its stability is limited by the stiffest frequency).
    pub fn is_explicit(self) -> bool {
        self != Integrator::ImplicitEuler
    }

    /// Whether the method takes the contact forces' dependence on velocity (their damping and
    /// friction) explicitly: all but `damped_euler`, `damped_rk4` and `implicit_euler`.
    pub fn takes_contact_damping_explicitly(self) -> bool {
        !matches!(
            self,
            Integrator::DampedEuler | Integrator::DampedRk4 | Integrator::ImplicitEuler
        )
    }

    /// Whether a step's accelerations are damped Euler's, implicit in the contact's velocities
    /// and recorded per stage (`damped_euler`, `damped_rk4`).
    pub fn is_damped(self) -> bool {
        matches!(self, Integrator::DampedEuler | Integrator::DampedRk4)
    }

    /// Whether the method chooses its internal steps by error control.
    pub fn is_adaptive(self) -> bool {
        self == Integrator::Dopri5
    }

    /// About how many forward dynamics (each with the pairs' reach proofs) an internal step
    /// evaluates: RK4's four stages (damped RK4's, each recorded once), implicit Euler's Newton residuals (about three once its
    /// Jacobian is kept), one for the others (damped Euler's contact is frozen at the step's
    /// start). Dormand–Prince's seven stages are counted, though it proves afresh.
    pub fn forwards_per_step(self) -> f64 {
        match self {
            Integrator::Rk4 | Integrator::DampedRk4 => 4.0,
            Integrator::ImplicitEuler => 3.0,
            Integrator::Dopri5 => 7.0,
            Integrator::Euler | Integrator::SemiImplicitEuler | Integrator::DampedEuler => 1.0,
        }
    }

    /// Order of accuracy (damped RK4's where nothing damps: in contact its damped forces are
    /// first order, as damped Euler's).
    pub fn order(self) -> usize {
        match self {
            Integrator::Euler
            | Integrator::SemiImplicitEuler
            | Integrator::DampedEuler
            | Integrator::ImplicitEuler => 1,
            Integrator::Rk4 | Integrator::DampedRk4 => 4,
            Integrator::Dopri5 => 5,
        }
    }
}

/// Positions, velocities and actuator activations: what an integrator advances.
#[derive(Clone, Debug, PartialEq)]
pub struct State<T> {
    /// Generalized positions `q`.
    pub q: Vec<T>,
    /// Generalized velocities `v`.
    pub v: Vec<T>,
    /// Actuator activations (`Model::na` of them; empty for a model without).
    pub act: Vec<T>,
}

impl<T> State<T> {
    /// Positions and velocities of a model without activations.
    pub fn new(q: Vec<T>, v: Vec<T>) -> State<T> {
        State {
            q,
            v,
            act: Vec::new(),
        }
    }

    /// A state holding no memory (no coordinate), to be written by [`State::assign`].
    pub fn empty() -> State<T> {
        State::new(Vec::new(), Vec::new())
    }
}

impl<T: Clone> State<T> {
    /// Makes this state a copy of `from`, reusing its buffers where they are large enough
    /// (`clone` allocates three vectors; a copy made at every step need not).
    pub fn assign(&mut self, from: &State<T>) {
        self.q.clone_from(&from.q);
        self.v.clone_from(&from.v);
        self.act.clone_from(&from.act);
    }
}
