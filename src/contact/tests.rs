//! Tests of the contact forces.

use super::*;
use jacobian::point_plane_force_jacobian_at;
use num_dual::Dual64;

#[test]
fn dissipation_variants_agree_at_the_ends() {
    for kind in [Dissipation::Paper, Dissipation::Smooth] {
        assert_eq!(kind.factor(0.0), 1.0);
        assert!(kind.factor(2.0f64).abs() < 1e-15);
        assert_eq!(kind.factor(2.5), 0.0);
        assert_eq!(kind.factor(-1.0), 2.0);
        let slope = |s: f64| kind.factor(Dual64::new(s, 1.0)).eps;
        assert!((slope(-1e-12) + 1.0).abs() < 1e-9 && (slope(1e-12) + 1.0).abs() < 1e-9);
        assert!(slope(2.0 - 1e-12).abs() < 1e-9);
    }
}

#[test]
fn smooth_dissipation_is_c2() {
    use num_dual::second_derivative;
    let d2 = |s: f64| second_derivative(|x| Dissipation::Smooth.factor(x), s).2;
    for s in [0.0, 2.0] {
        assert!((d2(s - 1e-9) - d2(s + 1e-9)).abs() < 1e-6, "jump at {s}");
    }
    let p2 = |s: f64| second_derivative(|x| Dissipation::Paper.factor(x), s).2;
    assert!(
        (p2(-1e-9) - p2(1e-9)).abs() > 0.4,
        "the paper's d is only C1 at 0"
    );
}

#[test]
fn point_plane_force_jacobian_matches_duals_and_central_differences() {
    // The hand-derived ∂λ/∂φ and ∂λ/∂v of `point_plane_force_jacobian` against Dual64
    // through `point_plane_force` (round-off: 1e-12 of the largest entry) and against
    // central differences (h = 1e-7 of the scale: 1e-6 relative), on both sides of the
    // dissipation's kinks (s < 0, 0 < s < 2, s > 2), pressed and separated, sliding and
    // nearly at rest, for both dissipation laws.
    // With a finite dissipation force (2 N and 20 N: the spring pushes with 10 N at 1 mm) the
    // spring moves the factor's argument too, and with the hold of a separation the speed does.
    // With a 4 mm margin the same readings 4 mm
    // farther out, and the force is the unshifted one at `φ - m`, to the bit. With adhesion
    // (3 N within a 0.5 mm gap, departure 7) the readings 0.3 mm and 0.6 mm out are inside the
    // gap and at its edge, where the window turns the pull off; an adhesion actuator's pull
    // (2 N, departure 9) alone and with the adhesion the same way.
    let n = Vector3::new(0.2, -0.3, 0.9).normalize();
    let laws = [Dissipation::Paper, Dissipation::Smooth]
        .into_iter()
        .flat_map(|d| {
            [
                (f64::INFINITY, false),
                (2.0, false),
                (20.0, false),
                (2.0, true),
                (20.0, true),
            ]
            .map(|f| (d, f))
        })
        .flat_map(|(d, f)| [0.0, 4e-3].map(|m| (d, f, m)))
        .flat_map(|(d, f, m)| {
            [
                (0.0, 0.0, None),
                (3.0, 5e-4, None),
                (0.0, 5e-4, Some(2.0)),
                (3.0, 5e-4, Some(2.0)),
            ]
            .map(|a| (d, f, m, a))
        });
    for (dissipation, (dissipation_force, hold_separation), margin, (adhesion, gap, pull)) in laws {
        let prm = ContactParams {
            eps3: 1e-4,
            stiffness: 1e4,
            dissipation_velocity: 0.1,
            stiction_velocity: 0.01,
            friction: 0.5,
            dissipation,
            dissipation_force,
            hold_separation,
            margin,
            adhesion,
            gap,
            pull,
            ..ContactParams::default()
        };
        for (depth, vn, vt) in [
            (1e-3, -0.05, 0.03),
            (2e-4, 0.05, -0.2),
            (-3e-4, 0.15, 1e-3),
            (-6e-4, -0.02, 0.05),
            (5e-4, 0.25, 0.1),
            (1e-3, 0.0, 0.0),
        ] {
            let t = n.cross(&Vector3::x()).normalize();
            let (r, v) = (
                n * (margin - depth) + t * 0.01,
                n * vn + t * vt + n.cross(&t) * 0.2 * vt,
            );
            let (lambda, dphi, dv) = point_plane_force_jacobian(&r, &n, &v, &prm);
            let phi = n.dot(&r);
            let unshifted = ContactParams { margin: 0.0, ..prm };
            assert_eq!(
                point_plane_force_at(phi, &n, &v, &prm),
                point_plane_force_at(phi - margin, &n, &v, &unshifted),
                "a margin is a shift of the reading"
            );
            assert_eq!(
                point_plane_force_jacobian_at(phi, &n, &v, &prm),
                point_plane_force_jacobian_at(phi - margin, &n, &v, &unshifted)
            );
            assert!((lambda - point_plane_force(&r, &n, &v, &prm)).norm() <= 1e-15 * lambda.norm());
            // Near s = 2 the factor is a cancellation of terms of order 1, so its round-off
            // (a few ε) times the spring's slope (at most k) sets a floor under the scale.
            let scale = dphi.amax().max(dv.amax()).max(1e-3 * prm.stiffness);
            // ∂λ/∂φ along r = r0 + s n (φ changes by s).
            let along = |s: f64| point_plane_force(&(r + n * s), &n, &v, &prm);
            let dual: Vector3<f64> = point_plane_force(
                &(r.map(Dual64::from) + n.map(Dual64::from) * Dual64::new(0.0, 1.0)),
                &n.map(Dual64::from),
                &v.map(Dual64::from),
                &prm.lift(),
            )
            .map(|x| x.eps);
            let fd = (along(1e-9) - along(-1e-9)) / 2e-9;
            assert!(
                (dphi - dual).amax() <= 1e-12 * scale,
                "{dissipation:?} {dissipation_force} {hold_separation} {adhesion} {pull:?} {depth} {vn}: dphi {dphi:?} vs dual {dual:?}"
            );
            assert!(
                (dphi - fd).amax() <= 1e-6 * scale,
                "{dissipation:?} {dissipation_force} {hold_separation} {adhesion} {pull:?} {depth} {vn}: dphi {dphi:?} vs fd {fd:?}"
            );
            for k in 0..3 {
                let mut e = Vector3::zeros();
                e[k] = 1.0;
                let dual: Vector3<f64> = point_plane_force(
                    &r.map(Dual64::from),
                    &n.map(Dual64::from),
                    &(v.map(Dual64::from) + e.map(|x| Dual64::new(0.0, x))),
                    &prm.lift(),
                )
                .map(|x| x.eps);
                let h = 1e-7 * v.norm().max(0.01);
                let fd = (point_plane_force(&r, &n, &(v + e * h), &prm)
                    - point_plane_force(&r, &n, &(v - e * h), &prm))
                    / (2.0 * h);
                assert!(
                    (dv.column(k) - dual).amax() <= 1e-12 * scale,
                    "{dissipation:?} {dissipation_force} {hold_separation} {adhesion} {pull:?} {depth} {vn}: dv[{k}] {:?} vs dual {dual:?}",
                    dv.column(k)
                );
                assert!(
                    (dv.column(k) - fd).amax() <= 1e-6 * scale,
                    "{dissipation:?} {dissipation_force} {hold_separation} {adhesion} {pull:?} {depth} {vn}: dv[{k}] {:?} vs fd {fd:?}",
                    dv.column(k)
                );
            }
        }
    }
}

#[test]
fn a_dissipation_force_bounds_the_damping_at_any_depth_and_keeps_it_passive() {
    // The damping coefficient at rest, -∂λ_n/∂v_n at v_n = 0, is c / (v_d (1 + c/F_d)): it
    // grows with the spring c (the depth) as the paper's c / v_d while c ≪ F_d, equals half
    // of that at c = F_d, and never passes F_d / v_d, however deep. The paper's law (infinite
    // F_d) grows without bound. At every speed the damping part λ_n - c has the sign of -v_n
    // (it only takes energy out).
    let n = Vector3::z();
    let base = ContactParams {
        stiffness: 1e5,
        eps3: 1e-4,
        dissipation_velocity: 0.1,
        ..ContactParams::default()
    };
    let capped = ContactParams {
        dissipation_force: 50.0,
        ..base
    };
    let cap = capped.dissipation_force / capped.dissipation_velocity;
    let damping = |prm: &ContactParams<f64>, depth: f64| {
        let (_, _, dv) = point_plane_force_jacobian(&(n * -depth), &n, &Vector3::zeros(), prm);
        -dv[(2, 2)]
    };
    let mut last = 0.0;
    for depth in [1e-5, 1e-4, 5e-4, 1e-3, 1e-2, 0.1, 1.0] {
        let c = base.stiffness * crate::scalar::softplus(depth, base.eps3);
        let (paper, ours) = (damping(&base, depth), damping(&capped, depth));
        assert!((paper - c / base.dissipation_velocity).abs() <= 1e-12 * paper);
        let expected = c / (capped.dissipation_velocity * (1.0 + c / capped.dissipation_force));
        assert!(
            (ours - expected).abs() <= 1e-12 * expected,
            "{depth}: {ours} vs {expected}"
        );
        assert!(
            ours < cap && ours > last,
            "{depth}: {ours} (cap {cap}, before {last})"
        );
        last = ours;
        if depth == 0.1 {
            assert!(
                ours > 0.99 * cap && paper > 190.0 * cap,
                "{ours} {paper} {cap}"
            );
        }
        for vn in [-3.0, -0.3, -0.01, 0.01, 0.1, 0.3] {
            let v = n * vn;
            let lambda = point_plane_force(&(n * -depth), &n, &v, &capped);
            assert!(
                (lambda.z - c) * vn < 0.0,
                "{depth} {vn}: {} vs {c}",
                lambda.z
            );
        }
    }
    // At c = F_d the damping is half the paper's.
    let depth = 5e-4; // c = 1e5 · s⁺(5e-4) ≈ 50.07 N
    let c = base.stiffness * crate::scalar::softplus(depth, base.eps3);
    let at = ContactParams {
        dissipation_force: c,
        ..base
    };
    assert!((damping(&at, depth) - 0.5 * damping(&base, depth)).abs() <= 1e-12 * c);
}

#[test]
fn point_plane_force_pushes_out_and_opposes_sliding() {
    let prm = ContactParams::default();
    let n = Vector3::z();
    let r = Vector3::new(0.0, 0.0, -1e-3);
    let f = point_plane_force(&r, &n, &Vector3::new(0.1, 0.0, 0.0), &prm);
    assert!(f.z > 0.0 && f.x < 0.0 && f.y == 0.0);
    // Friction bounded by μ λ_n.
    assert!(f.x.abs() <= prm.friction * f.z);
    // Separating fast (s > 2): no force.
    let f = point_plane_force(&r, &n, &Vector3::new(0.0, 0.0, 1.0), &prm);
    assert_eq!(f, Vector3::zeros());
}

#[test]
fn a_nan_temperature_gives_a_nan_contact_not_a_panic() {
    // ε2 = NaN makes the band's cutoff NaN: no entry is above it, so every entry is kept with
    // its terms (the band's test is the force's, "not above") and evaluated; the contact comes
    // out NaN for the guard to refuse, on the plain and on the chained (dual) path.
    use crate::geometry::Shape;
    use num_dual::Dual64;
    let a = Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.01));
    let b = Collider::Aopc(
        Shape::Box {
            half: Vector3::repeat(0.1),
        }
        .sample(0.01),
    );
    let fa = Frame {
        origin: Vector3::new(0.0, 0.0, 0.149),
        ..Frame::identity()
    };
    let prm = ContactParams {
        eps2: f64::NAN,
        ..ContactParams::default()
    };
    let pc = pair_contact(&a, &fa, &b, &Frame::identity(), &prm);
    assert!(pc.distance.is_nan() || pc.on_a.force.iter().any(|x| x.is_nan()));
    let lift = |f: &Frame<f64>| Frame {
        rotation: f.rotation.map(Dual64::from),
        origin: f.origin.map(Dual64::from),
        linvel: f.linvel.map(Dual64::from),
        angvel: f.angvel.map(Dual64::from),
    };
    let prm_d = prm.lift::<Dual64>();
    let pd = pair_contact(&a, &lift(&fa), &b, &Frame::identity(), &prm_d);
    assert!(pd.distance.re.is_nan() || pd.on_a.force.iter().any(|x| x.re.is_nan()));
}

/// Two dense clouds overlapping under a wide ε1 (every plane relevant at every point: the band's
/// terms would be `I1 I2` without a budget), with relative motion; the sphere's planes read
/// with half the box's ε1 (each cloud its own, docs/method.md, "ε1 follows the spacing"), so
/// that a side summed again with the other side's ε1 would not give the same bits.
pub(super) fn wide_overlap() -> (
    Collider,
    Collider,
    Frame<f64>,
    Frame<f64>,
    ContactParams<f64>,
) {
    use crate::geometry::Shape;
    let a = Collider::Aopc(Shape::Sphere { radius: 0.02 }.sample(0.002));
    let b = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.015, 0.01, 0.02),
        }
        .sample(0.002),
    );
    let fa = Frame {
        linvel: Vector3::new(0.01, -0.02, 0.03),
        angvel: Vector3::new(0.3, 0.1, -0.2),
        ..Frame::identity()
    };
    let fb = Frame {
        rotation: *nalgebra::Rotation3::from_euler_angles(0.2, -0.1, 0.4).matrix(),
        origin: Vector3::new(0.004, -0.003, 0.03),
        linvel: Vector3::new(-0.05, 0.01, -0.1),
        angvel: Vector3::new(-0.4, 0.2, 0.5),
    };
    let prm = ContactParams {
        eps1: 1e-4,
        eps1_scale: [0.5, 1.0],
        ..ContactParams::default()
    };
    (a, b, fa, fb, prm)
}

#[test]
fn terms_past_the_budget_are_summed_again_to_the_same_bits() {
    // The band keeps at most its budget of SSDF terms; an entry past it has its terms summed
    // again where its force is evaluated. With no term kept, a few, or all, every side sum is
    // the same to the last bit, and the distance too.
    let (a, b, fa, fb, prm) = wide_overlap();
    let rels = [fa.relative_to(&fb), fb.relative_to(&fa)];
    let run = |keep: usize| {
        let parts = pair_sides(
            &a,
            &b,
            &rels,
            &prm,
            BandWork {
                keep_terms: keep,
                scratch: &mut Scratch::default(),
                grads: None,
                memo: None,
            },
            || NoForceSink,
            |_, _, _, _| {},
        );
        let kept = parts.band.terms.len();
        let bits: Vec<u64> = parts
            .sums
            .iter()
            .flat_map(|s| s.flat())
            .chain([parts.dist.distance])
            .map(f64::to_bits)
            .collect();
        (bits, kept, parts.band.entries.len())
    };
    let (all, all_terms, entries) = run(usize::MAX);
    let (points, planes) = (a.len(), b.len());
    assert!(
        all_terms > 8 * (points + planes) && entries > 100,
        "a wide softmax: {all_terms} terms for {entries} entries"
    );
    for keep in [0, 1000, all_terms / 2, terms_budget(&a, &b)] {
        let (bits, kept, _) = run(keep);
        assert!(
            kept <= keep + points.max(planes),
            "{kept} terms kept at {keep}"
        );
        assert_eq!(bits, all, "budget {keep}");
    }
}

#[test]
fn a_tapes_entries_past_its_budget_replay_to_the_same_bits() {
    // Damped Euler's tape records at most its budget of terms; past it an entry keeps its query
    // point and a replay sums its terms again. Recorded with no budget, a small one and the
    // default, the wrenches at recording and at another velocity are the same bits.
    let (a, b, fa, fb, prm) = wide_overlap();
    let other = |f: &Frame<f64>, k: f64| Frame {
        linvel: f.linvel * k + Vector3::new(0.02, 0.0, -0.01),
        angvel: f.angvel * -k,
        ..*f
    };
    let (ga, gb) = (other(&fa, 1.5), other(&fb, -0.7));
    let bits = |w: &[Wrench<f64>; 2]| -> Vec<u64> {
        w.iter()
            .flat_map(|x| x.force.iter().chain(x.torque.iter()).copied())
            .map(f64::to_bits)
            .collect()
    };
    let record = |budget| {
        PairTape::record_within(
            &a,
            &fa,
            &b,
            &fb,
            &prm,
            (None, &mut Scratch::default()),
            budget,
        )
    };
    let (full, w_full) = record(usize::MAX);
    let default_budget = TAPE_TERMS_PER_POINT * (a.len() + b.len());
    assert!(full.recorded_terms() > default_budget, "a wide softmax");
    for budget in [0, 5000, default_budget] {
        let (tape, w) = record(budget);
        assert!(tape.recorded_terms() <= budget, "{budget}");
        assert_eq!(
            bits(&[w.on_a, w.on_b]),
            bits(&[w_full.on_a, w_full.on_b]),
            "recorded, budget {budget}"
        );
        assert_eq!(w.distance.to_bits(), w_full.distance.to_bits());
        assert_eq!(
            bits(&tape.replay(&a, &ga, &b, &gb, &prm)),
            bits(&full.replay(&a, &ga, &b, &gb, &prm)),
            "replayed, budget {budget}"
        );
    }
    // The default path is the budgeted one.
    let (tape, _) = PairTape::record(&a, &fa, &b, &fb, &prm, None, &mut Scratch::default());
    assert!(tape.recorded_terms() <= default_budget);
}

#[test]
fn a_pairs_wrenches_are_equal_and_opposite_on_one_line() {
    // Each point force's reaction acts on the plane body's material point at the query point
    // (docs/method.md, departure 6), so a pair adds neither force nor moment to the two
    // bodies together: their total linear and angular momentum are the pair's to exchange,
    // never to create. Checked with both bodies moving and turning, for the pruned and the
    // naive evaluation, a sampled sphere against a sampled box (softmax on both sides) and a
    // box against a half-space (one plane), pressed and sliding. Round-off: 1e-12 of the
    // largest force times the largest lever.
    use crate::geometry::Shape;
    let (a, b, fa, fb, prm) = wide_overlap();
    let cube = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.02, 0.03, 0.01),
        }
        .sample(0.005),
    );
    let ground = Collider::HalfSpace {
        point: Vector3::new(0.0, 0.0, 0.001),
        normal: Vector3::z(),
    };
    let tilted = Frame {
        rotation: *nalgebra::Rotation3::from_euler_angles(0.05, -0.03, 0.7).matrix(),
        origin: Vector3::new(0.3, -0.2, 0.0105),
        linvel: Vector3::new(0.2, -0.1, -0.05),
        angvel: Vector3::new(0.5, -0.3, 2.0),
    };
    let turning = Frame {
        angvel: Vector3::new(0.0, 0.0, 0.3),
        ..Frame::identity()
    };
    let prm_default = ContactParams::default();
    let cases = [
        (&a, fa, &b, fb, prm, "sphere against box"),
        (
            &cube,
            tilted,
            &ground,
            turning,
            prm_default,
            "box on a half-space",
        ),
    ];
    for (a, fa, b, fb, prm, what) in cases {
        for (c, how) in [
            (pair_contact(a, &fa, b, &fb, &prm), "pruned"),
            (pair_contact_naive(a, &fa, b, &fb, &prm), "naive"),
        ] {
            let largest = c.on_a.force.norm().max(c.on_b.force.norm());
            assert!(largest > 1e-3, "{what}: the bodies press ({largest} N)");
            let lever = fa.origin.norm().max(fb.origin.norm()) + 0.05;
            let net_force = c.on_a.force + c.on_b.force;
            let net_moment = c.on_a.torque
                + fa.origin.cross(&c.on_a.force)
                + c.on_b.torque
                + fb.origin.cross(&c.on_b.force);
            assert!(
                net_force.norm() <= 1e-12 * largest,
                "{what} ({how}): net force {net_force:?} of {largest} N"
            );
            assert!(
                net_moment.norm() <= 1e-12 * largest * lever,
                "{what} ({how}): net moment {net_moment:?} N m of {largest} N"
            );
        }
    }
}

#[test]
fn an_adhesive_contact_presses_as_before_pulls_within_its_gap_and_stays_in_its_bound() {
    // Departure 7 (docs/method.md): with adhesion δ and gap g the point–plane force at rest is
    // the ordinary spring k (m - φ) in contact, a pull of δ from δ/k past the margin to the
    // gap's edge, nothing past it; its friction scales with what presses (none in the gap).
    // Sharp ε3 (10 µm) so the plateaus are flat to e^-10; the tolerances are those tails.
    let n = Vector3::z();
    let (k, eps3, delta, gap, margin) = (1e4, 1e-5, 3.0, 5e-4, 2e-3);
    let plain = ContactParams {
        stiffness: k,
        eps3,
        dissipation_velocity: 0.1,
        stiction_velocity: 0.01,
        friction: 0.5,
        margin,
        ..ContactParams::default()
    };
    let prm = ContactParams {
        adhesion: delta,
        gap,
        ..plain
    };
    let at = |y: f64, v: Vector3<f64>, p: &ContactParams<f64>| {
        point_plane_force_at(margin + y, &n, &v, p)
    };
    // Pressed 1 mm: the plain spring (10 N); sliding, the friction is μ times the spring,
    // which is what presses plus δ (MuJoCo's budget μ (f_N + δ)).
    let sliding = Vector3::new(0.3, 0.0, 0.0);
    let (a, b) = (at(-1e-3, sliding, &prm), at(-1e-3, sliding, &plain));
    assert!((a.z - b.z).abs() <= 1e-9 * b.z, "{a:?} vs {b:?}");
    let budget = b.x * (b.z + delta) / b.z;
    assert!(
        (a.x - budget).abs() <= 1e-9 * budget.abs(),
        "{a:?} vs {b:?}"
    );
    // In the gap: a pull of δ along -n, no friction.
    for y in [delta / k + 10.0 * eps3, 4e-4, gap - 10.0 * eps3] {
        let f = at(y, sliding, &prm);
        assert!((f.z + delta).abs() <= 1e-4 * delta, "{y}: {f:?}");
        assert!(f.x.abs() <= 1e-4 * delta, "{y}: {f:?}");
    }
    // Past the gap the pull is gone: e^-40 of δ 40 ε3 out, exactly 0 past the reach.
    assert!(at(gap + 40.0 * eps3, sliding, &prm).norm() <= 1e-17 * delta);
    let reach = prm.bound_margin() - margin + 746.0 * eps3;
    assert_eq!(at(reach * 1.001, sliding, &prm), Vector3::zeros());
    // The bound the pruning reads, and the damping only takes energy out.
    let speeds = [
        (-0.3, 0.1),
        (-0.01, 0.0),
        (0.02, 0.5),
        (0.15, -0.05),
        (0.4, 0.0),
    ];
    assert_bounded_and_passive(|y, v| at(y, v, &prm), &prm, 400, &speeds);
}

/// The bound the pruning reads, `|λ| ≤ k* s⁺(m* - φ) (1 + |v_n|/v_d) √(1 + μ²)`, and the
/// damping only taking energy out (`λ_n(v) - λ_n(0)` has the sign of `-v_n`), at `n` readings
/// `y` past the margin from 2 mm in to 1 mm out, each at the normal and sliding speeds
/// `speeds` (`(v_n, v_t)`); `at(y, v)` is the point force there along `z`.
pub(super) fn assert_bounded_and_passive(
    at: impl Fn(f64, Vector3<f64>) -> Vector3<f64>,
    prm: &ContactParams<f64>,
    n: usize,
    speeds: &[(f64, f64)],
) {
    let (ks, ms) = (prm.bound_stiffness(), prm.bound_margin());
    for i in 0..n {
        let y = -2e-3 + 3e-3 * (i as f64 / (n - 1) as f64);
        let rest = at(y, Vector3::zeros()).z;
        for &(vn, vt) in speeds {
            let f = at(y, Vector3::new(vt, 0.0, vn));
            let bound = ks
                * crate::scalar::softplus(ms - (prm.margin + y), prm.eps3)
                * (1.0 + vn.abs() / prm.dissipation_velocity)
                * (1.0 + prm.friction.powi(2)).sqrt();
            assert!(
                f.norm() <= bound * (1.0 + 1e-12),
                "{y} {vn}: {f:?} > {bound}"
            );
            assert!((f.z - rest) * vn <= 0.0, "{y} {vn}: {} vs {rest}", f.z);
        }
    }
}

#[test]
fn a_dissipation_force_bounds_the_approach_and_holds_a_separation_to_a_few_v_d() {
    // With the hold (implicit integrators) V = v_d (1 + (c/F_d) g(v_n/v_d)), g = 1 - tanh(x/2)
    // (docs/method.md, departure 4). Approaching, g ≥ 1 keeps the damping force λ_n - c below
    // F_d |v_n| / v_d at any depth; separating, g ≤ 2 e^{-x} lets the force vanish from
    // v_n = v_d (2.2 + ln(1 + 4c/F_d)) on, a few v_d at any depth (else 2 V, 200 v_d at 100 F_d).
    let n = Vector3::z();
    let prm = ContactParams {
        stiffness: 1e5,
        eps3: 1e-4,
        dissipation_velocity: 0.1,
        dissipation_force: 10.0,
        hold_separation: true,
        ..ContactParams::default()
    };
    for depth in [1e-4, 1e-3, 1e-2, 3.5e-2] {
        let c = prm.stiffness * crate::scalar::softplus(depth, prm.eps3);
        let ratio = c / prm.dissipation_force;
        for vn in [-10.0, -1.0, -0.1, -1e-3] {
            let lambda = point_plane_force(&(n * -depth), &n, &(n * vn), &prm);
            let damping = lambda.z - c;
            let bound = prm.dissipation_force * vn.abs() / prm.dissipation_velocity;
            assert!(damping > 0.0 && damping < bound, "{depth} {vn}: {damping}");
        }
        let cap = prm.dissipation_velocity * (2.2 + (1.0 + 4.0 * ratio).ln());
        for vn in [cap, 2.0 * cap, 100.0 * cap] {
            let lambda = point_plane_force(&(n * -depth), &n, &(n * vn), &prm);
            assert_eq!(lambda, Vector3::zeros(), "{depth} {vn}");
        }
        // Below the cap it still pushes; the cap stays under 12 v_d at c = 350 F_d.
        let lambda = point_plane_force(&(n * -depth), &n, &(n * (0.5 * cap)), &prm);
        assert!(lambda.z > 0.0 && cap < 1.2, "{depth}: {cap}");
    }
}
