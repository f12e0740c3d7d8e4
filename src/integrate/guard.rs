//! The energy guard of [`Model::advance`](crate::model::Model::advance) (see [`AdvanceOptions::energy_guard`](crate::integrate::AdvanceOptions::energy_guard)): the balance
//! it keeps over a run ([`EnergyLedger`]), its working state during one call, and the estimate
//! of the energy stored in contact ([`contact_energy`]).

use super::advance::StepFailure;
use super::cache::KinematicsMemo;
use crate::contact::ContactParams;
use crate::dynamics::Kinematics;
use crate::integrator::{Integrator, State};
use crate::model::Model;

impl Model {
    /// The actuators' work over one internal step from `(τ0, v0)` to `(τ1, v1)` (generalized
    /// actuator forces and velocities at its two ends), as the integrator puts it in:
    /// `h τ̄ · (v0 + v1)/2`, with `τ̄` the actuator force the method applies over the step: held
    /// from the start in the Euler family, taken at the end in implicit Euler, the mean of the
    /// two ends in the others (the trapezoid of the Runge–Kutta stages). For a free mass this
    /// is the kinetic energy the step adds, exactly for the Euler family and implicit Euler; a
    /// trapezoid of the power `τ·v` instead misses most of it when the force changes within a
    /// step (a position actuator starting a light finger: 400 N at the start, 128 N at the end
    /// of the first 2 ms step), and the guard took that for created energy.
    pub(super) fn step_work(&self, before: &Held, after: &Held, h: f64) -> f64 {
        let weight = match self.integrator {
            Integrator::Euler | Integrator::SemiImplicitEuler | Integrator::DampedEuler => 0.0,
            Integrator::ImplicitEuler => 1.0,
            Integrator::Rk4 | Integrator::DampedRk4 | Integrator::Dopri5 => 0.5,
        };
        let actuators = (0..before.tau.len())
            .map(|k| {
                let tau = before.tau[k] * (1.0 - weight) + after.tau[k] * weight;
                tau * 0.5 * (before.v[k] + after.v[k])
            })
            .sum::<f64>();
        // The moving surfaces' power, by the trapezoid.
        (actuators + 0.5 * (before.surface + after.surface)) * h
    }

    /// The power the moving surfaces put into the bodies at `s` (W; MuJoCo's geom
    /// `surfacevel`, docs/method.md, departure 8): per pair whose surfaces move and in reach,
    /// `-Σ (R l)·F + (R w)·τ` over its two bodies, `(l, w)` a body's surface flow and `(F, τ)`
    /// the contact's wrench on it (about its origin). That is `-Σ λ·s` over the contact's point
    /// forces `λ` and the flows' difference `s` where they act: the power by which friction
    /// drags the bodies along, exact where the flow is tangent to the surfaces in contact
    /// (rollers, turntables, a belt's face); where it is not (a belt's end face) it also counts
    /// the normal force against the flow's normal part, which the law does not read. 0 where
    /// no surface moves.
    pub(super) fn surface_power(&self, s: &State<f64>, prm: &ContactParams<f64>) -> f64 {
        if self.pairs.iter().all(|p| p.surface.is_none()) {
            return 0.0;
        }
        let kin = self.tree.kinematics(&s.q, &s.v);
        let mut scratch = crate::collision::Scratch::default();
        let mut power = 0.0;
        for pair in self.pairs.iter().filter(|p| p.surface.is_some()) {
            let (Some(ca), Some(cb)) = (&self.colliders[pair.a], &self.colliders[pair.b]) else {
                continue;
            };
            let p = pair.params(prm);
            let seed = crate::collision::Seed::AfterRoot;
            if self.out_of_reach_with(pair, &kin, &p, (None, seed), &mut scratch) {
                continue;
            }
            let (fa, fb) = (&kin.frames[pair.a], &kin.frames[pair.b]);
            let pc = crate::contact::pair_contact(ca, fa, cb, fb, &p);
            let flows = pair.surface.as_ref().expect("filtered");
            for (frame, flow, wrench) in [(fa, &flows[0], &pc.on_a), (fb, &flows[1], &pc.on_b)] {
                power -= (frame.rotation * flow.lin).dot(&wrench.force)
                    + (frame.rotation * flow.ang).dot(&wrench.torque);
            }
        }
        power
    }

    /// The actuators' generalized forces and the velocities at `s`; nothing where those forces
    /// are zero whatever the state: no actuators and no joint's actuator force range to clamp
    /// into (their work is then zero, a sum over nothing in [`Model::step_work`]).
    pub(super) fn held(&self, s: &State<f64>, ctrl: &[f64], prm: &ContactParams<f64>) -> Held {
        let surface = self.surface_power(s, prm);
        if self.actuators.is_empty() && self.actuator_ranges.is_empty() {
            return Held {
                tau: Vec::new(),
                v: Vec::new(),
                surface,
            };
        }
        Held {
            surface,
            tau: (self.actuator_forces(&s.q, &s.v, &self.driven_inputs(ctrl, &s.act, &s.q, None)))
                .as_slice()
                .to_vec(),
            v: s.v.clone(),
        }
    }

    /// The guard's state at the start of a call from `state` at time `t0` (s), with the contacts
    /// there (`None`: none evaluated; the energy stored in them is then the ledger's estimate
    /// where it carries on with one, [`EnergyLedger::stored`], else none), continuing `ledger`
    /// if it was left at this state and these parameters. `None` when the energy is not finite
    /// (it cannot be judged).
    pub(super) fn energy_monitor(
        &self,
        state: &State<f64>,
        ctrl: &[f64],
        prm: &ContactParams<f64>,
        contacts: Option<&[Option<crate::contact::PairContact<f64>>]>,
        t0: f64,
        ledger: Option<&EnergyLedger>,
    ) -> Option<EnergyMonitor> {
        let pulls = self.pulls(&self.driven_inputs(ctrl, &state.act, &state.q, None));
        let carried = ledger.filter(|l| l.at == *state && l.params == *prm);
        let in_contact = match contacts {
            Some(c) => contact_energy(&self.pairs, c, prm, &pulls),
            None => carried.and_then(|l| l.stored).unwrap_or(0.0),
        };
        let stored = in_contact + self.limits_drift(&state.q);
        let floor = self.moving_mass() * (self.tree.gravity.norm() * 1e-3 + 0.5 * 1e-4);
        let ledger = match carried {
            // Carried on: the mechanical and kinetic energies at this state are the ones the
            // last call's final check computed, kept with the ledger (not computed again: on a
            // scene of free bodies that was a tenth of a step). The energy stored in contact counts as
            // energy in motion only as far as the balance admits it, `U ≤ A - E` (`A` the
            // allowance the state passed): the estimate reads the pair's whole force, damping
            // included, and in a blow-up that drives a body into another it reads thousands of
            // times the energy the run has (gymnasium's ant: 1.8e5 J in a 4 J run), which would
            // raise the allowance that is to catch the blow-up. So capped, `S ≤ A - V` at every
            // step (`V` the potential energy), and without actuators no accepted state has more
            // kinetic energy than `2 (E₀ + U₀ + E_floor - V_min)`.
            Some(l) => {
                let admitted = if stored > 0.0 {
                    let headroom = l.allowed(floor) - l.energy;
                    stored.min(headroom.max(0.0))
                } else {
                    0.0
                };
                // The state it was left at is known (`state`): the call's own ledger holds none
                // until the call leaves it at its end state.
                let mut carried = EnergyLedger {
                    at: State::empty(),
                    scale: l.scale.max(l.kinetic + admitted),
                    ..*l
                };
                carried.tighten(l.energy, l.kinetic, stored, t0, floor);
                carried
            }
            _ => {
                let e = self.energy(&state.q, &state.v);
                EnergyLedger::started(state.clone(), *prm, e.total(), e.kinetic, stored, t0)
            }
        };
        (ledger.reference.is_finite() && ledger.scale.is_finite()).then(|| EnergyMonitor {
            ledger,
            last: self.held(state, ctrl, prm),
            floor,
            energy: f64::NAN,
        })
    }
}

/// The energy balance the guard keeps over a run (see [`AdvanceOptions::energy_guard`](crate::integrate::AdvanceOptions::energy_guard)):
/// carried from one [`Model::advance_cached`](crate::model::Model::advance_cached) call to the next in the [`SolverCache`](crate::integrate::SolverCache), so that
/// an energy that grows a little in every communication step is seen as it adds up.
#[derive(Clone, Debug, PartialEq)]
pub struct EnergyLedger {
    /// The state the ledger was left at; a call from any other state starts a new ledger.
    pub at: State<f64>,
    /// The contact parameters it was kept with; other parameters start a new ledger (they
    /// change the energy stored in contact).
    pub params: ContactParams<f64>,
    /// Time the ledger started (s, for messages).
    pub since: f64,
    /// Energy at the start, `E + U` (J): mechanical energy and the estimate of the energy
    /// stored in contact ([`contact_energy`]).
    pub reference: f64,
    /// Work of the actuators since the start (J, trapezoidal rule on the internal steps).
    pub work: f64,
    /// Sum of the magnitudes of that work's increments (J): what its rounding scales with.
    pub gross_work: f64,
    /// Largest energy in motion seen: `T + U` at the start of each call (`U` only as far as
    /// the balance admits it, see [`AdvanceOptions::energy_guard`](crate::integrate::AdvanceOptions::energy_guard); all of it where
    /// the ledger starts), `T` after every internal step (J).
    pub scale: f64,
    /// Kinetic energy `T` at `at` (J), as the guard computed it there: a call that carries the
    /// ledger on starts from it instead of evaluating the energy again.
    pub kinetic: f64,
    /// Mechanical energy `E` at `at` (J), as the guard computed it there. Not kept in a
    /// saved model state: a restored ledger computes it again from `at`, to the same bits.
    pub energy: f64,
    /// The estimate of the energy stored in contact at `at` (J, [`contact_energy`]) where the
    /// call that left the ledger found it: implicit Euler's last step reads it at its Newton
    /// iterations' last evaluated iterate, one Newton step from `at` (its iterations stop on a
    /// step they do not evaluate: a step within their tolerance, or up to `(1 - θ)/θ` times it
    /// where they contract at a fast rate θ). A call that carries the ledger on takes it instead of
    /// listing every pair's contact at its start again: on `box_stack` that listing was a
    /// third of implicit Euler's step, on three free bodies out of reach a sixth. `None`: not
    /// known (the next call lists the contacts).
    pub stored: Option<f64>,
}

impl EnergyLedger {
    /// Its estimate of the energy stored in contact ([`EnergyLedger::stored`]) if it was left
    /// at `state` with the parameters `prm`.
    pub(super) fn stored_at(&self, state: &State<f64>, prm: &ContactParams<f64>) -> Option<f64> {
        self.stored
            .filter(|_| self.at == *state && self.params == *prm)
    }

    /// The most mechanical energy a state may have (J), given the energy floor `floor` (J):
    /// `E₀ + U₀ + W + ½ (S + Σ|ΔW|) + E_floor` ([`AdvanceOptions::energy_guard`](crate::integrate::AdvanceOptions::energy_guard)).
    pub(super) fn allowed(&self, floor: f64) -> f64 {
        self.reference + self.work + 0.5 * (self.scale + self.gross_work) + floor
    }

    /// A ledger that starts at `at` (mechanical energy `energy`, kinetic `kinetic`, estimated
    /// contact energy `stored`, at `t`), kept with the contact parameters `params`.
    fn started(
        at: State<f64>,
        params: ContactParams<f64>,
        energy: f64,
        kinetic: f64,
        stored: f64,
        t: f64,
    ) -> EnergyLedger {
        EnergyLedger {
            at,
            params,
            since: t,
            reference: energy + stored,
            work: 0.0,
            gross_work: 0.0,
            scale: kinetic + stored,
            kinetic,
            energy,
            stored: None,
        }
    }

    /// Starts the balance afresh at a state of mechanical energy `energy`, kinetic energy
    /// `kinetic` and estimated contact energy `stored` (J), reached at `t` (s).
    fn restart(&mut self, energy: f64, kinetic: f64, stored: f64, t: f64) {
        self.since = t;
        self.reference = energy + stored;
        self.work = 0.0;
        self.gross_work = 0.0;
        self.scale = kinetic + stored;
        self.kinetic = kinetic;
        self.energy = energy;
    }

    /// Moves the balance's start to the state the run has reached (mechanical energy `energy`,
    /// kinetic `kinetic`, estimated contact energy `stored`, at `t`) when its balance is not
    /// above the start's, `E + U ≤ E₀ + U₀ + W`: the run has lost energy since. Without a
    /// source, `E + U - W` only decreases along the exact motion, so every state the run has
    /// passed bounds what follows, not only the first; the guard takes the lowest, with the
    /// margin `½ S` counted from there. A growth that adds up never restarts it (its balance
    /// stays above the start's), so it is still judged from the start. What this catches: a run
    /// that spends a large start before it blows up. gymnasium's ant with RK4 at 10 ms starts
    /// with 1.37 kJ in its ankles' limit springs; while SCM's limit dampers could pull, they
    /// spent it in 0.2 s, and the ant gained 84 J in its first touch of the floor (6.7 J to
    /// 90.5 J in one step), well inside the allowance counted from the start.
    ///
    /// Only where the contacts hold no more than the energy floor `floor`: the estimate of `U`
    /// reads low while bodies part (their damping then cancels part of the spring's force), and
    /// a start taken there would count the energy the parting gives back as created. (A guard
    /// by reasoning: no measured run has needed it yet.)
    pub(super) fn tighten(&mut self, energy: f64, kinetic: f64, stored: f64, t: f64, floor: f64) {
        if stored <= floor && energy + stored <= self.reference + self.work {
            self.restart(energy, kinetic, stored, t);
        }
    }
}

/// What the work of the next internal step starts from: the actuators' generalized forces
/// (N or N·m), the velocities, and the moving surfaces' power.
#[derive(Clone, Debug)]
pub(super) struct Held {
    tau: Vec<f64>,
    v: Vec<f64>,
    /// The moving surfaces' power (W, [`Model::surface_power`]).
    surface: f64,
}

/// The guard's working state during one [`Model::advance`](crate::model::Model::advance) call.
pub(super) struct EnergyMonitor {
    /// The balance since the ledger started.
    pub(super) ledger: EnergyLedger,
    /// Actuator forces and velocities after the last internal step.
    pub(super) last: Held,
    /// Energy below which growth is not judged (J).
    pub(super) floor: f64,
    /// Mechanical energy `E` after the last internal step (J): with the contacts the next
    /// step's forward dynamics find there, where the balance may restart
    /// ([`EnergyLedger::tighten`]).
    pub(super) energy: f64,
}

impl EnergyMonitor {
    /// What the guard leaves for the next call: the balance so far, at the end state `end`
    /// with the parameters `params` (the state copied into the buffers of the ledger the last
    /// call left, `old`), and the contact energy `stored` found there, if known
    /// ([`EnergyLedger::stored`]).
    pub(super) fn leave(
        monitor: Option<EnergyMonitor>,
        end: &State<f64>,
        params: &ContactParams<f64>,
        old: Option<EnergyLedger>,
        stored: Option<f64>,
    ) -> Option<EnergyLedger> {
        monitor.map(|m| {
            let mut at = old.map_or_else(State::empty, |l| l.at);
            at.assign(end);
            EnergyLedger {
                at,
                params: *params,
                stored,
                ..m.ledger
            }
        })
    }
}

impl Model {
    /// The guard's check of the state `s` after an internal step (`at`: its time, its number
    /// and its length): a diverged coordinate, then, with a `monitor`, the energy balance. The
    /// kinematics of `s` it computed for the balance (into `buffers`, kinematics done with, if
    /// given) are handed back.
    pub(super) fn guard_check(
        &self,
        monitor: &mut Option<EnergyMonitor>,
        s: &State<f64>,
        (t, step, h): (f64, usize, f64),
        ctrl: &[f64],
        prm: &ContactParams<f64>,
        buffers: Option<Kinematics<f64>>,
    ) -> Result<Option<Kinematics<f64>>, StepFailure> {
        if let Some(quantity) = self.first_non_finite(s) {
            return Err(StepFailure::NonFinite {
                time: t,
                step,
                h,
                quantity,
            });
        }
        let Some(m) = monitor.as_mut() else {
            return Ok(None);
        };
        let mut kin = buffers.unwrap_or_else(Kinematics::empty);
        self.tree.kinematics_into(&s.q, &s.v, &[], &mut kin);
        let e = self.energy_at(&kin, &s.q, &s.v);
        let now = self.held(s, ctrl, prm);
        let dw = self.step_work(&m.last, &now, h);
        m.ledger.work += dw;
        m.ledger.gross_work += dw.abs();
        m.last = now;
        m.ledger.scale = m.ledger.scale.max(e.kinetic);
        m.ledger.kinetic = e.kinetic;
        let total = e.total();
        m.energy = total;
        m.ledger.energy = total;
        if !total.is_finite() || total > m.ledger.allowed(m.floor) {
            let l = &m.ledger;
            return Err(StepFailure::EnergyGrowth {
                time: t,
                step,
                h,
                since: l.since,
                from: l.reference,
                to: total,
                input: l.work,
                allowed: l.allowed(m.floor),
            });
        }
        Ok(Some(kin))
    }

    /// The guard's kinematics `kin` of a state, as the next forward dynamics from it can take
    /// them: with no mocap body (every mocap body at its scene pose, which the next evaluation's
    /// inputs may not keep, otherwise), else recycled into `memo` for their buffers.
    pub(super) fn kinematics_kept(
        &self,
        kin: Option<Kinematics<f64>>,
        memo: &mut KinematicsMemo,
    ) -> Option<Kinematics<f64>> {
        match kin {
            Some(kin) if !self.tree.mocap.is_empty() => {
                memo.recycle(kin);
                None
            }
            kin => kin,
        }
    }
}

/// An estimate of the elastic energy stored in the contacts `contacts` of `pairs` (J), per pair the
/// larger of `ε3 |F| + |F|²/(2k)` (`F`: the force between the two bodies) and `k D²` (`D < 0`:
/// the smooth penetration). A pair out of reach (`None`, see
/// [`Model::contact_forces`](crate::model::Model::contact_forces)) stores nothing.
///
/// A point–plane spring `k s`, `s = s⁺_ε3(-φ)`, stores `k ε3² P(φ/ε3)`, with
/// `P(y) = ∫_y^∞ ln(1 + e^{-t}) dt = -Li₂(-e^{-y})` (the work its force does as the point
/// leaves to infinity); `k (ε3 s + ½ s²)` has the same tails (`k ε3² e^{-y}` far out, `½ k φ²`
/// deep in) and lies between 1.00 and 1.25 times it for every `φ` (checked numerically on
/// `y ∈ [-20, 20]`). A pair's force is such springs averaged by the softmax weights, times the
/// dissipation factor, so with `s = |F|/k` this is an estimate, not a bound: it reads high
/// while the bodies approach (damping adds to `|F|`) and low where forces of one pair cancel
/// (one body inside another: the `k D²` term covers that). The old per-step bound `k (D² + ε3²)`
/// allowed `k ε3²` for every pair in reach however far apart (10 J at `k = 1e9`, `ε3 = 1e-4`)
/// where a 1 kg sphere resting on a plane stores about `ε3 m g ≈ 1 mJ`. An adhesive pair adds
/// `δ min((D - m)⁺, g)`, the work its pull can still do (docs/method.md, departure 7), and a
/// pair an adhesion actuator pulls `a` the same way with its pull `a` from `pulls`
/// ([`Model::pulls`](crate::model::Model::pulls), at the controls of now; departure 9).
pub fn contact_energy(
    pairs: &[crate::model::Pair],
    contacts: &[Option<crate::contact::PairContact<f64>>],
    prm: &ContactParams<f64>,
    pulls: &[Option<f64>],
) -> f64 {
    pairs
        .iter()
        .zip(contacts)
        .filter_map(|(pair, pc)| pc.as_ref().map(|pc| (pair, pc)))
        .filter(|(_, pc)| pc.distance.is_finite())
        .map(|(pair, pc)| {
            let k = pair.stiffness_at(prm.eps3).unwrap_or(prm.stiffness);
            let f = pc.on_a.force.norm();
            // The spring reads the distance less the pair's margin.
            let deep = (pair.margin - pc.distance).max(0.0);
            // An adhesive pair (departure 7) pulls with up to δ from its gap's edge in to its
            // margin: the work that pull can still do, `δ` times how far it can still pull,
            // counted from the well's bottom so that what is stored is never negative (the
            // balance reads it as energy that may turn into motion).
            // The adhesion actuators' pull (departure 9) likewise, at the controls of now.
            let pull = pair.adhesion + pair.pull(pulls).map_or(0.0, |p| p.max(0.0));
            let well = pull * (pc.distance - pair.margin).clamp(0.0, pair.gap);
            (prm.eps3 * f + f * f / (2.0 * k)).max(k * deep * deep) + well
        })
        .sum()
}
