//! Each contact pair's stiffness and dissipation velocity from the file's `solref` and
//! `solimp`, as MuJoCo means them (docs/mjcf.md, "Contact stiffness from solref and solimp"):
//! the geoms' values mixed per geom pair as MuJoCo mixes them (`priority`, `solmix`), or a
//! `<pair>`'s own, turned into SCM's linear spring and Hunt–Crossley damping for the body
//! pair's effective mass so that a body at rest sinks as deep as in MuJoCo and its contact is
//! damped there as MuJoCo's is.

use super::collide::mixed_contact;
use super::*;

impl Builder {
    /// The `solref` and `solimp` of `el` over `base` (the values not written; MuJoCo reads
    /// fewer entries than the full two and five and keeps the rest).
    pub(super) fn softness(&self, el: &Element, base: Softness) -> Result<Softness, SceneError> {
        self.softness_named(el, base, ["solref", "solimp"])
    }

    /// A joint's or tendon's `solreflimit` and `solimplimit` (MuJoCo's defaults where absent).
    pub(super) fn limit_softness_of(&self, el: &Element) -> Result<Softness, SceneError> {
        self.softness_named(el, Softness::default(), ["solreflimit", "solimplimit"])
    }

    /// [`Builder::softness`] from the attributes named `names` (`<option>`'s `o_solref` and
    /// `o_solimp`).
    fn softness_named(
        &self,
        el: &Element,
        base: Softness,
        names: [&str; 2],
    ) -> Result<Softness, SceneError> {
        let mut out = base;
        for (name, slot) in [
            (names[0], &mut out.solref[..]),
            (names[1], &mut out.solimp[..]),
        ] {
            let Some(text) = el.attr(name) else { continue };
            match parse_floats(text) {
                Some(v) if !v.is_empty() && v.len() <= slot.len() => {
                    slot[..v.len()].copy_from_slice(&v)
                }
                _ => {
                    return Err(self.err(
                        el,
                        format!("{name}=\"{text}\": expected 1 to {} numbers", slot.len()),
                    ))
                }
            }
        }
        Ok(out)
    }

    /// `<option>`'s contact override values (`o_margin`, `o_solref`, `o_solimp`, the sliding
    /// friction of `o_friction`), which act under `<flag override="enable">`.
    pub(super) fn contact_override(&mut self, el: &Element) -> Result<(), SceneError> {
        let mut o = self.contact_override;
        if let Some(m) = self.float(el, "o_margin")? {
            o.margin = m;
        }
        o.softness = self.softness_named(el, o.softness, ["o_solref", "o_solimp"])?;
        if let Some(v) = self.friction_list(el, "o_friction", 5)? {
            o.friction = v[0];
        }
        self.contact_override = o;
        Ok(())
    }

    /// The file's integrator as SCM runs it: `scm_integrator` over `<option integrator>`, over
    /// MuJoCo's default (its Euler, SCM's `damped_euler`). An unknown name is left to
    /// [`Builder::finish`]'s settings loop to refuse.
    pub(super) fn integrator_as_run(&self) -> Integrator {
        self.text
            .iter()
            .rev()
            .find(|(n, _, _)| n == "scm_integrator")
            .and_then(|(_, v, _)| Integrator::from_name(v))
            .or(self.option_integrator)
            .unwrap_or(Integrator::DampedEuler)
    }

    /// Gives each pair its own stiffness and dissipation velocity from its `solref` and
    /// `solimp` ([`PairLaw`]), unless the scene sets `scm_stiffness` or
    /// `scm_dissipation_velocity`, which then apply to every pair (and the FMU's parameters of
    /// those names with them). A `<pair>`'s values are its own; otherwise each geom pair's
    /// are mixed ([`mix`]) and, where a body pair touches through geom pairs that give
    /// different laws, the stiffest is taken and a warning says so. Returns each pair's law
    /// (`None` where the scene's settings apply).
    pub(super) fn pair_laws(
        &mut self,
        tree: &Tree,
        pairs: &mut [Pair],
        colliding: &[bool],
        eps3: f64,
        step: f64,
        integrator: Integrator,
    ) -> Vec<Option<PairLaw>> {
        let set = |name: &str| self.numeric.iter().any(|(n, _, _)| n == name);
        let per_weight = self
            .numeric
            .iter()
            .rev()
            .find(|(n, _, _)| n == "scm_dissipation_force")
            // 0: no bound (the paper's law).
            .map(|(_, v, _)| if *v > 0.0 { *v } else { f64::INFINITY })
            .or(Some(if integrator.takes_contact_damping_explicitly() {
                EXPLICIT_DISSIPATION_FORCE
            } else {
                IMPLICIT_DISSIPATION_FORCE
            }));
        if set("scm_stiffness") || set("scm_dissipation_velocity") || pairs.is_empty() {
            if set("scm_dissipation_force") && !pairs.is_empty() {
                self.warnings.push(
                    "scm_dissipation_force acts on the pairs' laws from solref and solimp; the scene's scm_stiffness or scm_dissipation_velocity replaces them, so it has no effect: remove one or the other".into(),
                );
            }
            return vec![None; pairs.len()];
        }
        let weights = weights::body_weights(tree);
        let moving = weights::moving_masses(tree);
        let g = tree.gravity.norm();
        let refsafe = self.flags.refsafe.then_some(step);
        let body_of = |name: &str| self.geoms.iter().find(|g| g.name == name).map(|g| g.body);
        let explicit: Vec<((usize, usize), Softness, u32)> = self
            .explicit_pairs
            .iter()
            .filter_map(|p| {
                let (x, y) = (body_of(&p.geoms[0])?, body_of(&p.geoms[1])?);
                Some(((x.min(y), x.max(y)), p.softness, p.condim))
            })
            .collect();
        let over = self.friction_override();
        let mut notes = Vec::new();
        let laws = pairs
            .iter_mut()
            .map(|pair| {
                // MuJoCo's effective mass, unless the inverse weights are a rounding error
                // (below MuJoCo's `mjMINVAL`, 1e-15): a centre of mass on its only joint's axis
                // cannot move, and the pair is sized for the mass that moves with its two
                // bodies instead (`weights::moving_masses`).
                let w = weights[pair.a].0 + weights[pair.b].0;
                let moving = moving[pair.a] + moving[pair.b];
                let mass = if w > 1e-15 {
                    1.0 / w
                } else if moving > 0.0 {
                    moving
                } else {
                    return None;
                };
                let law = |s: Softness, (mu, condim): (f64, u32)| {
                    let cone = cone_share(self.cone, mu, condim);
                    PairLaw::new(s, mass, cone, g, eps3, refsafe, per_weight)
                };
                // Each geom pair's friction and condim as MuJoCo mixes them; a `<pair>`'s own
                // condim, and the friction the pair was given.
                let geom_pairs: Vec<_> = self
                    .geom_pairs(pair.a, pair.b, colliding)
                    .into_iter()
                    .map(|(x, y)| (mix(&x.softness, &y.softness), mixed_contact(x, y, over)))
                    .collect();
                let explicit_pair = explicit.iter().find(|(k, _, _)| *k == (pair.a, pair.b));
                let own = |condim: u32| (pair.friction.unwrap_or(1.0), condim);
                let candidates: Vec<PairLaw> = match explicit_pair {
                    _ if self.flags.override_contacts => {
                        let s = self.contact_override.softness;
                        match explicit_pair {
                            Some((_, _, condim)) => vec![law(s, own(*condim))],
                            None => geom_pairs.iter().map(|(_, c)| law(s, *c)).collect(),
                        }
                    }
                    Some((_, s, condim)) => vec![law(*s, own(*condim))],
                    None => geom_pairs.iter().map(|(s, c)| law(*s, *c)).collect(),
                };
                let stiffest = candidates
                    .iter()
                    .copied()
                    .reduce(|a, b| if b.stiffness > a.stiffness { b } else { a })?;
                if candidates.iter().any(|c| c.softness != stiffest.softness) {
                    notes.push(format!(
                        "bodies '{}' and '{}': their geoms give different solref/solimp; SCM's contact acts between whole bodies and uses the stiffest, solref {:?} solimp {:?}",
                        self.bodies[pair.a].name, self.bodies[pair.b].name, stiffest.softness.solref, stiffest.softness.solimp
                    ));
                }
                pair.stiffness = Some(stiffest.stiffness);
                pair.rest = Some([stiffest.weight, stiffest.depth]);
                pair.dissipation_velocity = Some(stiffest.dissipation_velocity);
                pair.dissipation_force = Some(stiffest.dissipation_force);
                pair.hold_separation = !integrator.takes_contact_damping_explicitly();
                Some(stiffest)
            })
            .collect();
        self.warnings.extend(notes);
        laws
    }

    /// Gives each pair its stiction floor ([`Pair::stiction_floor`]): `κ h g`, `h` the file's
    /// step (as `refsafe` reads it), `g` the gravity (or [`NOMINAL_GRAVITY`] without), `κ` the
    /// scene's `scm_stiction_floor` or, under an integrator that takes the friction explicitly
    /// ([`Integrator::takes_contact_damping_explicitly`]), [`EXPLICIT_STICTION_FLOOR`]; none
    /// otherwise, and none where the scene sets its own `scm_stiction_velocity` (as its own
    /// `scm_stiffness` keeps the paper's law: it chose the value).
    pub(super) fn stiction_floors(
        &self,
        tree: &Tree,
        pairs: &mut [Pair],
        step: f64,
        integrator: Integrator,
    ) {
        let kappa = self
            .numeric
            .iter()
            .rev()
            .find(|(n, _, _)| n == "scm_stiction_floor")
            .map(|(_, v, _)| *v)
            .unwrap_or(
                if integrator.takes_contact_damping_explicitly()
                    && !self
                        .numeric
                        .iter()
                        .any(|(n, _, _)| n == "scm_stiction_velocity")
                {
                    EXPLICIT_STICTION_FLOOR
                } else {
                    0.0
                },
            );
        let g = tree.gravity.norm();
        let g = if g > 0.0 { g } else { NOMINAL_GRAVITY };
        for pair in pairs {
            pair.stiction_floor = kappa * step * g;
        }
    }

    /// A geom's `solref`, `solimp`, `solmix` and `priority`.
    pub(super) fn geom_softness(&self, el: &Element) -> Result<GeomSoftness, SceneError> {
        let softness = self.softness(el, Softness::default())?;
        let solmix = self.float(el, "solmix")?.unwrap_or(1.0);
        let priority = match el.attr("priority") {
            None => 0,
            Some(p) => p
                .trim()
                .parse()
                .map_err(|_| self.err(el, format!("priority=\"{p}\": expected a whole number")))?,
        };
        Ok(GeomSoftness {
            softness,
            solmix,
            priority,
        })
    }
}

/// MuJoCo's smallest value taken as non-zero (`mjMINVAL`).
const MIN_VALUE: f64 = 1e-15;
/// MuJoCo's bounds on the impedance (`mjMINIMP`, `mjMAXIMP`).
const IMPEDANCE_RANGE: (f64, f64) = (1e-4, 0.9999);
/// The gravity at which a scene without gravity is calibrated (m/s²): a contact's stiffness is
/// the one that gives MuJoCo's resting depth under it.
pub const NOMINAL_GRAVITY: f64 = 9.81;

/// MuJoCo's soft-constraint parameters of a contact: `solref` (time constant and damping ratio;
/// both negative: stiffness and damping) and `solimp` (impedance at zero depth `d0`, at depth
/// `width` and beyond `dmax`, the width, the midpoint and the power of the curve between).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Softness {
    /// `solref`.
    pub solref: [f64; 2],
    /// `solimp`.
    pub solimp: [f64; 5],
}

impl Default for Softness {
    /// MuJoCo's defaults: `solref="0.02 1"`, `solimp="0.9 0.95 0.001 0.5 2"`.
    fn default() -> Self {
        Softness {
            solref: [0.02, 1.0],
            solimp: [0.9, 0.95, 0.001, 0.5, 2.0],
        }
    }
}

/// `<option>`'s `o_margin`, `o_solref`, `o_solimp` and `o_friction` (its sliding friction),
/// which replace every contact's own under `<flag override="enable">`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactOverride {
    /// `o_margin` (m, default 0).
    pub margin: f64,
    /// `o_solref` and `o_solimp` (MuJoCo's defaults).
    pub softness: Softness,
    /// `o_friction`'s first entry (default 1).
    pub friction: f64,
}

impl Default for ContactOverride {
    fn default() -> Self {
        ContactOverride {
            margin: 0.0,
            softness: Softness::default(),
            friction: 1.0,
        }
    }
}

/// A geom's contact attributes that MuJoCo mixes per geom pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeomSoftness {
    /// `solref` and `solimp`.
    pub softness: Softness,
    /// `solmix` (default 1): the weight of this geom's values against the other's.
    pub solmix: f64,
    /// `priority` (default 0): the geom of higher priority gives its values whole.
    pub priority: i32,
}

impl Default for GeomSoftness {
    fn default() -> Self {
        GeomSoftness {
            softness: Softness::default(),
            solmix: 1.0,
            priority: 0,
        }
    }
}

/// The values of a geom pair as MuJoCo's collision driver mixes them: those of the geom of
/// higher `priority`; at equal priority `solimp` weighted by `solmix₁ / (solmix₁ + solmix₂)`
/// (half and half when both are zero), and `solref` weighted the same when both are time
/// constants (positive), else the smaller of each entry.
pub fn mix(a: &GeomSoftness, b: &GeomSoftness) -> Softness {
    if a.priority != b.priority {
        return if a.priority > b.priority {
            a.softness
        } else {
            b.softness
        };
    }
    let w = match (a.solmix >= MIN_VALUE, b.solmix >= MIN_VALUE) {
        (true, true) => a.solmix / (a.solmix + b.solmix),
        (false, false) => 0.5,
        (false, true) => 0.0,
        (true, false) => 1.0,
    };
    let (x, y) = (&a.softness, &b.softness);
    let blend = |p: f64, q: f64| w * p + (1.0 - w) * q;
    let solref = if x.solref[0] > 0.0 && y.solref[0] > 0.0 {
        [
            blend(x.solref[0], y.solref[0]),
            blend(x.solref[1], y.solref[1]),
        ]
    } else {
        [x.solref[0].min(y.solref[0]), x.solref[1].min(y.solref[1])]
    };
    let mut solimp = [0.0; 5];
    for (k, s) in solimp.iter_mut().enumerate() {
        *s = blend(x.solimp[k], y.solimp[k]);
    }
    Softness { solref, solimp }
}

impl Softness {
    /// MuJoCo's impedance `d(r)` at penetration depth `r ≥ 0` (m): `d0` at zero, `dmax` from
    /// `width` on, between them `d0 + y (dmax - d0)` with `y` the power curve through the
    /// midpoint (`x = r / width`: `x^p / mid^(p-1)` up to `mid`, `1 - (1-x)^p / (1-mid)^(p-1)`
    /// after); the values bounded to MuJoCo's `[1e-4, 0.9999]`.
    pub fn impedance(&self, r: f64) -> f64 {
        let [d0, dmax, width, mid, power] = self.solimp;
        let (lo, hi) = IMPEDANCE_RANGE;
        let (d0, dmax) = (d0.clamp(lo, hi), dmax.clamp(lo, hi));
        let (mid, power) = (mid.clamp(lo, hi), power.max(1.0));
        if d0 == dmax || width <= MIN_VALUE {
            return 0.5 * (d0 + dmax);
        }
        let x = r.abs() / width;
        if x >= 1.0 {
            return dmax;
        }
        let y = if power == 1.0 {
            x
        } else if x <= mid {
            x.powf(power) / mid.powf(power - 1.0)
        } else {
            1.0 - (1.0 - x).powf(power) / (1.0 - mid).powf(power - 1.0)
        };
        d0 + y * (dmax - d0)
    }

    /// `dmax`, bounded to MuJoCo's `[1e-4, 0.9999]`: the impedance from `width` on.
    pub fn dmax(&self) -> f64 {
        let (lo, hi) = IMPEDANCE_RANGE;
        self.solimp[1].clamp(lo, hi)
    }

    /// MuJoCo's reference stiffness and damping per unit of effective mass, `(K, B)`, in its
    /// reference acceleration `-B v - K d(r) r`: with a time constant `τ` and damping ratio `ζ`,
    /// `K = 1 / (dmax² τ² ζ²)` and `B = 2 / (dmax τ)`, `τ` held at no less than twice the step
    /// where `refsafe` is on (`refsafe_step`: the step then); with negative values, `K =
    /// -solref[0] / dmax²` and `B = -solref[1] / dmax`.
    pub fn reference(&self, refsafe_step: Option<f64>) -> (f64, f64) {
        let (lo, hi) = IMPEDANCE_RANGE;
        let dmax = self.solimp[1].clamp(lo, hi);
        let [a, b] = self.solref;
        if a > 0.0 {
            let tau = refsafe_step.map_or(a, |h| a.max(2.0 * h));
            (1.0 / (dmax * dmax * tau * tau * b * b), 2.0 / (dmax * tau))
        } else {
            (-a / (dmax * dmax), -b / dmax)
        }
    }

    /// The depth at which MuJoCo's contact holds a load of `g` per unit of its effective mass
    /// at rest: the root of `r d(r)² / (1 - d(r)) = g / K` (a contact at rest accelerates
    /// neither way, so its regularized force `d / (1 - d) · (a_ref / Â)` carries the load).
    /// Found by bisection: the left side grows with `r` wherever `d` does not fall.
    pub fn resting_depth(&self, g: f64, refsafe_step: Option<f64>) -> f64 {
        let (k, _) = self.reference(refsafe_step);
        let load = g / k;
        let f = |r: f64| {
            let d = self.impedance(r);
            r * d * d / (1.0 - d) - load
        };
        let (mut lo, mut hi) = (0.0, 1e-6);
        while f(hi) < 0.0 && hi < 1e3 {
            lo = hi;
            hi *= 2.0;
        }
        for _ in 0..200 {
            let m = 0.5 * (lo + hi);
            if f(m) < 0.0 {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    }

    /// MuJoCo's damping ratio of the contact's linearized motion, `B / (2 √K)`: `ζ` itself for
    /// a time constant, `b / (2 √k)` for negative values.
    pub fn damping_ratio(&self, refsafe_step: Option<f64>) -> f64 {
        let (k, b) = self.reference(refsafe_step);
        b / (2.0 * k.sqrt())
    }
}

/// The dissipation force over each pair's resting force `m̂ g` under an integrator that takes the
/// contact's damping explicitly (RK4 among them), unless the scene sets `scm_dissipation_force`:
/// the damping stays within 25 % of the paper's law up to the resting force and stops growing
/// at five times its resting value (docs/method.md, departure 4). Chosen by measurement among
/// 0.5, 1, 2, 4, 8 and infinity (docs/mjcf.md, "Contact on, against MuJoCo's spread").
pub const EXPLICIT_DISSIPATION_FORCE: f64 = 4.0;

/// The dissipation force over each pair's resting force `m̂ g` under an integrator that takes the
/// contact's damping implicitly (`damped_euler`, `implicit_euler`, `damped_rk4`: MuJoCo's Euler,
/// implicit integrators and RK4), unless the scene sets `scm_dissipation_force`. There the bound
/// also holds a separation's speed to a few `v_d` (`Pair::hold_separation`), so a deep overlap
/// is released without being thrown. The paper's law, whose damping grows with the depth, held
/// an arm's wrist on its base for 100 ms where MuJoCo's bounces off (robosuite's xArm7) and
/// threw a pushed block ten times as far as MuJoCo's (the T-push written MuJoCo's way). Chosen
/// by measurement among 4, 8, 16 and infinity (docs/mjcf.md, "Contact on, against MuJoCo's
/// spread").
pub const IMPLICIT_DISSIPATION_FORCE: f64 = 8.0;

/// The stiction floor `κ` of a pair under an integrator that takes the friction explicitly:
/// its stiction velocity at least `κ h μ g`. The friction's slope at zero slip is `μ N / v_s`,
/// about `μ g / v_s` per unit of the mass it holds, and RK4 is stable on a decay rate `λ` only
/// while `h λ` is below 2.79. A foot carries more than its own mass's weight, so the measured
/// bound is higher: gymnasium's ant at rest on its legs under RK4 at 10 ms is refused by the
/// guard at the default 1 cm/s (κ 0.1) and at κ 0.5, rests at κ 0.75 and 1 but turns about
/// its vertical axis at 0.019 rad/s (a limit cycle of the friction at the edge of RK4's
/// stability; MuJoCo's does not turn), 0.001 rad/s at κ 1.5, and rests still from κ 2
/// (docs/mjcf.md, "Stiction floor").
pub const EXPLICIT_STICTION_FLOOR: f64 = 2.0;

/// MuJoCo's friction cone as a scene sets it (`<option cone impratio>`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// `cone="elliptic"` (MuJoCo's default is pyramidal).
    pub elliptic: bool,
    /// `impratio` (default 1), held at no less than MuJoCo's `mjMINVAL` (1e-15).
    pub impratio: f64,
}

impl Default for Cone {
    fn default() -> Self {
        Cone {
            elliptic: false,
            impratio: 1.0,
        }
    }
}

/// The share `c` of MuJoCo's friction cone in a contact's normal force, against one normal row
/// regularized by `R = (1 - d)/d · Â` (docs/mjcf.md, "Contact stiffness from solref and
/// solimp"): 1 for an elliptic cone, a frictionless contact (`condim` 1) or no friction. A
/// pyramidal cone of `condim` `n` holds the normal on its `2(n - 1)` edges, each regularized
/// by `2 μ² (1 + μ²) R / impratio` (MuJoCo's `mj_makeImpedance` and `mj_diagApprox`: an
/// edge's inverse weight is `Â (1 + μ²)`, and every edge takes the regularization that makes
/// the pyramid's friction as soft as the elliptic cone's), so at a depth it pushes
/// `c = (n - 1) impratio / (μ² (1 + μ²))` times one row's force: 1 at `μ` = 1 (condim 3), 1.36
/// at 0.9, 0.120 at 1.9 (`μ` the contact's sliding friction).
pub fn cone_share(cone: Cone, mu: f64, condim: u32) -> f64 {
    if cone.elliptic || condim <= 1 || mu <= 0.0 || !mu.is_finite() {
        return 1.0;
    }
    f64::from(condim - 1) * cone.impratio.max(MIN_VALUE) / (mu * mu * (1.0 + mu * mu))
}

/// SCM's contact law of one pair, sized from MuJoCo's: the stiffness `k` that holds the pair's
/// effective mass `m̂` under gravity `g` at MuJoCo's resting depth `r` (`k s⁺_ε3(-φ) = m̂ g` at
/// `φ = -r`), and the dissipation velocity and force that give the motion about that rest
/// MuJoCo's damping there, `m̂ d(r) B` (MuJoCo's constraint moves as `r̈ = -d B ṙ - d² K r + …`).
/// In a pyramidal friction cone ([`cone_share`] `c`) the normal is one row regularized by `R / c`:
/// `r` is the depth one row would rest at under `g / c`, and `d` becomes `c d / (1 - d + c d)`.
/// SCM's damping coefficient is `c / V(c)` (the slope of the dissipation factor is `-1` at zero
/// speed), `V(c) = v_d (1 + c/F_d)`: the paper's law (`F_d` infinite) gives `m̂ g / v_d` at rest,
/// so `v_d = g / (d(r) B)`, whatever the mass. The integrator's default or a scene's
/// `scm_dissipation_force` `f` sets `F_d = f m̂ g`: the damping is then `m̂ g / ((1 + 1/f) v_d)` at rest, so
/// `v_d = g / ((1 + 1/f) d(r) B)`, and deeper it approaches `(1 + f)` times that and stops
/// growing, as MuJoCo's is bounded by `dmax B` (docs/method.md, departure 4). The
/// motion about rest then decays as MuJoCo's, with
/// the time constant `2 / (d B)` (`τ dmax / d`, about `τ`), but oscillates faster: the spring
/// that holds MuJoCo's static depth is `(1 - d)⁻¹` times MuJoCo's `d² K` (11.6 times at the
/// default `solimp`), so its damping ratio is `√(1 - d)` times MuJoCo's (0.29 for ζ = 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairLaw {
    /// The pair's `solref` and `solimp` (mixed).
    pub softness: Softness,
    /// Its effective mass `m̂ = 1 / (w₁ + w₂)`, `w` MuJoCo's translational `body_invweight0`;
    /// the mass that moves with the two bodies where `w₁ + w₂` is below 1e-15 (kg).
    pub mass: f64,
    /// The share `c` of MuJoCo's friction cone in its normal force at a depth, against a
    /// single normal row's ([`cone_share`]): 1 for an elliptic cone or a frictionless contact.
    pub cone: f64,
    /// MuJoCo's resting depth under `g` (m).
    pub depth: f64,
    /// The resting force `m̂ g` (N; `g` nominal where the model has none).
    pub weight: f64,
    /// SCM's stiffness (N/m): `weight / s⁺_ε3(depth)` at the scene's ε3.
    pub stiffness: f64,
    /// SCM's dissipation velocity at zero force (m/s).
    pub dissipation_velocity: f64,
    /// SCM's dissipation force, `f m̂ g` (N): `f` the scene's `scm_dissipation_force`, or the
    /// integrator's ([`EXPLICIT_DISSIPATION_FORCE`], [`IMPLICIT_DISSIPATION_FORCE`]); infinite
    /// where the scene sets 0.
    pub dissipation_force: f64,
}

impl PairLaw {
    /// The law for `softness` on effective mass `mass` (kg) in a friction cone of share `cone`
    /// ([`cone_share`]), gravity `g` (m/s², its magnitude;
    /// [`NOMINAL_GRAVITY`] where it is zero), SCM's `eps3` (m), MuJoCo's `refsafe` step and the
    /// dissipation force per unit of resting force `f` (the scene's `scm_dissipation_force`, or
    /// the integrator's default, [`EXPLICIT_DISSIPATION_FORCE`] or [`IMPLICIT_DISSIPATION_FORCE`];
    /// `None`: infinite, the paper's law).
    pub fn new(
        softness: Softness,
        mass: f64,
        cone: f64,
        g: f64,
        eps3: f64,
        refsafe_step: Option<f64>,
        dissipation_force: Option<f64>,
    ) -> PairLaw {
        let g = if g > 0.0 { g } else { NOMINAL_GRAVITY };
        // The cone's edges hold `c` times a single row's force at a depth: MuJoCo's contact
        // rests where a single row would under `g / c`.
        let depth = softness.resting_depth(g / cone, refsafe_step);
        // The contact force's own softplus, s⁺_ε3(r).
        let weight = mass * g;
        let stiffness = weight / crate::scalar::softplus(depth, eps3);
        let (_, b) = softness.reference(refsafe_step);
        let f = dissipation_force.unwrap_or(f64::INFINITY);
        // The normal's impedance in the cone: its regularization is `R / c`, so
        // `(1 - d') / d' = (1 - d) / (c d)`.
        let d = softness.impedance(depth);
        let d_cone = cone * d / (1.0 - d + cone * d);
        let dissipation_velocity = g / ((1.0 + 1.0 / f) * d_cone * b);
        PairLaw {
            softness,
            mass,
            cone,
            depth,
            weight,
            stiffness,
            dissipation_velocity,
            dissipation_force: f * mass * g,
        }
    }
}

#[cfg(test)]
#[path = "contact_tests.rs"]
mod tests;
