//! The band walk, the kept candidates and the reach proofs against the naive evaluation, and a
//! pair's memory.

use super::*;
use crate::geometry::ssdf::SpringShape;

#[test]
fn the_band_keeps_each_entrys_ssdf_terms_within_its_cutoff() {
    // `band_of` with `keep_terms`: the band is the entries within the cutoff Φ_min + M2 ε2 (the
    // entries whose point force can be evaluated), and each keeps its SSDF's terms, and they are that
    // point's relevant set (as `Relevant::find` gives it alone) with the weights
    // exp(-(d_i - d_min)/ε1), summing to the entry's Φ. A sharp ε1 (each point walks on its
    // own) and a soft one (a leaf shares one ball), a sphere against a box at random
    // overlapping poses.
    let sphere = Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.006));
    let cube = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.04, 0.03, 0.05),
        }
        .sample(0.006),
    );
    let mut s = 5u64;
    let (mut kept, mut dropped) = (0, 0);
    for case in 0..24 {
        let eps1 = if case % 2 == 0 { 1e-7 } else { 3e-5 };
        let eps2 = 2e-3;
        let axis = vec3(&mut s).normalize();
        let fa = Frame::<f64>::identity();
        let fb = Frame {
            rotation: *nalgebra::Rotation3::from_axis_angle(
                &nalgebra::Unit::new_normalize(axis),
                3.0 * lcg(&mut s),
            )
            .matrix(),
            origin: vec3(&mut s) * 0.02 + Vector3::new(0.0, 0.0, 0.08),
            ..Frame::identity()
        };
        let rels = [fa.relative_to(&fb), fb.relative_to(&fa)];
        let band = band_of(
            &sphere,
            &cube,
            &rels,
            [eps1; 2],
            eps2,
            SpringShape {
                eps3: 1e-4,
                margin: 0.0,
            },
            BandWork {
                keep_terms: usize::MAX,
                scratch: &mut Scratch::default(),
                grads: None,
                memo: None,
            },
        );
        let cutoff = band.min + band.margin * eps2;
        // Entries evaluated beyond the final cutoff were dropped, and the kept terms of the
        // rest close up: the entries' ranges tile `terms` in order.
        dropped += band.evaluated - band.entries.len();
        let mut end = 0;
        for e in &band.entries {
            let (from, to) = e.terms.expect("terms kept");
            assert_eq!(from, end, "case {case}: the terms close up");
            end = to;
        }
        assert_eq!(end as usize, band.terms.len(), "case {case}");
        for e in &band.entries {
            assert!(
                e.phi <= cutoff,
                "case {case}: the band holds only entries within the cutoff"
            );
            let (from, to) = e.terms.expect("an entry within the cutoff keeps its terms");
            kept += 1;
            let terms = &band.terms[from as usize..to as usize];
            let (query, planes) = if e.side == 0 {
                (&sphere, &cube)
            } else {
                (&cube, &sphere)
            };
            let (Collider::Aopc(q), Collider::Aopc(o)) = (query, planes) else {
                unreachable!()
            };
            let rel = &rels[e.side as usize];
            let x = rel.rotation * q.bvh().points[e.k as usize] + rel.translation;
            let mut alone = Relevant::default();
            alone.find(o, &x, eps1, usize::MAX);
            let mut want: Vec<u32> = alone.items.iter().map(|&(k, _)| k).collect();
            let mut got: Vec<u32> = terms.iter().map(|&(k, _)| k).collect();
            want.sort_unstable();
            got.sort_unstable();
            assert_eq!(
                got, want,
                "case {case}: the kept planes are the relevant set"
            );
            let (mut z, mut acc) = (0.0, 0.0);
            for &(k, w) in terms {
                let r = x - o.bvh().points[k as usize];
                let expect = (-(r.norm_squared() - alone.dmin) / eps1).exp();
                assert!(
                    (w - expect).abs() <= 1e-12 * expect.max(1e-300),
                    "{w} vs {expect}"
                );
                z += w;
                acc += w * o.bvh().normals[k as usize].dot(&r);
            }
            // Φ is the SSDF raised to the polytope's floor (which leaves most entries as
            // they are).
            let phi = planes.raise(&x, acc / z);
            assert!((phi - e.phi).abs() <= 1e-12 * (1.0 + e.phi.abs()));
        }
    }
    assert!(kept > 100 && dropped > 0, "kept {kept}, dropped {dropped}");
}

#[test]
fn kept_candidates_give_the_same_band_to_the_last_bit() {
    // A cube sliding and turning against a sphere along a path of small steps, the band walked
    // with the pair's kept candidates (`CandidateMemo`) and without: the same entries, Φ,
    // d_min, spring bounds and kept terms, bit for bit, at sharp and soft ε1 and a wide and a narrow cutoff (ε2), while the kept
    // balls both serve (hits) and are replaced (misses, the path moving several spacings),
    // points are left out by their balls' floors, and nodes whose proof failed are not tried
    // again at once. Balls no query reads are dropped after `UNUSED_WALKS` walks; an ε1 changed between calls
    // drops what was kept. What is kept stays within its budget, `O(I1 + I2)`.
    let sphere = Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.006));
    let cube = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.04, 0.03, 0.05),
        }
        .sample(0.006),
    );
    let bits = |band: &SeparationBand<f64>| {
        let entries: Vec<_> = band
            .entries
            .iter()
            .map(|e| {
                (
                    e.side,
                    e.k,
                    e.phi.to_bits(),
                    e.dmin.to_bits(),
                    e.springs.to_bits(),
                    e.terms,
                )
            })
            .collect();
        let terms: Vec<_> = band.terms.iter().map(|&(k, w)| (k, w.to_bits())).collect();
        (entries, terms, band.min.to_bits(), band.skipped)
    };
    let mut s = 11u64;
    for (eps1, eps2) in [(1e-7, 2e-3), (3e-5, 2e-3), (1e-7, 2e-4), (3e-5, 1e-3)] {
        let mut kept = CandidateMemo::default();
        let axis = nalgebra::Unit::new_normalize(vec3(&mut s));
        let drift = vec3(&mut s) * 1.2e-4;
        let mut last = None;
        for step in 0..140 {
            let t = step as f64;
            let fb = Frame {
                rotation: *nalgebra::Rotation3::from_axis_angle(&axis, 0.3 + 2e-3 * t).matrix(),
                origin: Vector3::new(0.0, 0.0, 0.088) + drift * t,
                ..Frame::identity()
            };
            let fa = Frame::<f64>::identity();
            let rels = [fa.relative_to(&fb), fb.relative_to(&fa)];
            last = Some(rels);
            let walk = |kept: Option<&mut CandidateMemo>| {
                band_of(
                    &sphere,
                    &cube,
                    &rels,
                    [eps1; 2],
                    eps2,
                    SpringShape {
                        eps3: 1e-4,
                        margin: 0.0,
                    },
                    BandWork {
                        keep_terms: usize::MAX,
                        scratch: &mut Scratch::default(),
                        grads: None,
                        memo: kept,
                    },
                )
            };
            let (fresh, with_kept) = (walk(None), walk(Some(&mut kept)));
            assert!(fresh.entries.len() > 10, "in contact at step {step}");
            let (k, f) = (bits(&with_kept), bits(&fresh));
            let first = k.0.iter().zip(&f.0).position(|(x, y)| x != y);
            assert_eq!(first, None, "ε1 {eps1}, step {step}: first differing entry");
            assert!(k == f, "ε1 {eps1}, step {step}: the bands differ");
        }
        let counts = kept.counts();
        // At the soft ε1 a ball holds about every plane of the other body (its reach, 3.7 cm,
        // spans the 5 cm sphere): the side's budget keeps a few of them and the other points
        // walk ([`CANDIDATES_PER_POINT`]); at the sharp one every ball fits.
        let (i1, i2) = (sphere.len(), cube.len());
        let bound = 8192 * (i1 + i2) + (1 << 20);
        assert!(
            kept.heap_bytes() <= bound,
            "ε1 {eps1}: {} bytes",
            kept.heap_bytes()
        );
        let soft = eps1 > 1e-6;
        assert!(
            (soft && counts.unkept > 0 && counts.hits > 0
                || !soft && counts.unkept == 0 && counts.hits + counts.above > 4 * counts.misses)
                && counts.replaced > 0
                && counts.dropped > 0
                && counts.compactions > 0
                && counts.untried > 0,
            "ε1 {eps1}: {counts:?}"
        );
        band_of(
            &sphere,
            &cube,
            &last.unwrap(),
            [2.0 * eps1; 2],
            eps2,
            SpringShape {
                eps3: 1e-4,
                margin: 0.0,
            },
            BandWork {
                keep_terms: usize::MAX,
                scratch: &mut Scratch::default(),
                grads: None,
                memo: Some(&mut kept),
            },
        );
        assert_eq!(kept.counts().hits, counts.hits, "another ε1 drops them");
        // (At the soft ε1 the polytope's floor proves the far nodes first, and no point is
        // left for its ball's floor.)
        assert!(
            eps2 > 1e-3 || soft || counts.above > 0,
            "ε1 {eps1}: no point left out by its floor"
        );
    }
}

#[test]
fn the_reach_proofs_first_look_at_one_point_changes_no_answer() {
    // `cloud_beyond` asks, once the root is not settled, whether one point near the other body
    // is already within the threshold (`seed_within`), and then gives up at once. Against the
    // walk alone, over a sphere and a box at random poses from deep contact to well apart, at
    // thresholds around the reach distance: the same answer every time, with the shortcut
    // taken in contact and proofs succeeding apart.
    let sphere = Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.008));
    let cube = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.04, 0.03, 0.05),
        }
        .sample(0.008),
    );
    let floor = Collider::HalfSpace {
        point: Vector3::zeros(),
        normal: Vector3::z(),
    };
    let mut s = 23u64;
    let (mut proven, mut shortcut) = (0, 0);
    for case in 0..300 {
        let axis = nalgebra::Unit::new_normalize(vec3(&mut s));
        let rot = *nalgebra::Rotation3::from_axis_angle(&axis, 3.0 * lcg(&mut s)).matrix();
        let gap = -0.01 + 0.05 * lcg(&mut s);
        let t = [3e-4, 3.5e-3, 1e-2][case % 3];
        // Every other case may settle points by their springs (ε3 0.1 mm, resting at 0).
        let spring = match case % 2 {
            0 => SpringShape::NONE,
            _ => SpringShape {
                eps3: 1e-4,
                margin: 0.0,
            },
        };
        let (query, planes, tr) = match case % 3 {
            // The cube's points against the sphere, its centre `gap` beyond contact along z.
            0 => (
                &cube,
                &sphere,
                Vector3::new(0.0, 0.0, 0.1 + gap) + vec3(&mut s) * 0.01,
            ),
            // The sphere's points against the cube.
            1 => (
                &sphere,
                &cube,
                Vector3::new(0.0, 0.0, 0.1 + gap) + vec3(&mut s) * 0.01,
            ),
            // The cube above a floor.
            _ => (&cube, &floor, Vector3::new(0.0, 0.0, 0.03 + gap)),
        };
        let Collider::Aopc(q) = query else {
            unreachable!()
        };
        let budget = reach_budget(q.len());
        let question = ReachQuestion {
            planes,
            rot: &rot,
            tr: &tr,
            t,
            eps1: 1e-5,
            spring,
            room: 0.0,
        };
        let beyond = |seed| {
            cloud_beyond_with(
                &question,
                q,
                (&mut { budget }, &mut Scratch::default()),
                seed,
            )
        };
        let (with, without, first) = (
            beyond(Seed::AfterRoot),
            beyond(Seed::Off),
            beyond(Seed::First),
        );
        assert_eq!(with, without, "case {case}: gap {gap}, threshold {t}");
        assert_eq!(
            first, without,
            "seed first, case {case}: gap {gap}, threshold {t}"
        );
        proven += with.proven() as usize;
        // (The allowance's `vmax` only widens it: 0 here, so these are surely within.)
        let seen = seed_within(&question, q.bvh(), 0.0, &mut Relevant::default());
        assert!(
            !(seen && with.proven()),
            "case {case}: a point within, yet proven beyond"
        );
        shortcut += seen as usize;
    }
    assert!(
        proven > 30 && shortcut > 30,
        "proven {proven}, shortcut {shortcut}"
    );
}

#[test]
fn the_bands_gradients_follow_its_entries_after_what_the_caller_had() {
    // `band_of` pushes one gradient per entry after whatever `grads` held, and drops those of
    // the entries beyond the cutoff with them: a vector that held one gradient before ends
    // with it, then the same gradients as from an empty one, one per entry.
    let sphere = Collider::Aopc(Shape::Sphere { radius: 0.05 }.sample(0.006));
    let cube = Collider::Aopc(
        Shape::Box {
            half: Vector3::new(0.04, 0.03, 0.05),
        }
        .sample(0.006),
    );
    let fa = Frame::<f64>::identity();
    let fb = Frame {
        origin: Vector3::new(0.01, 0.0, 0.092),
        ..Frame::identity()
    };
    let rels = [fa.relative_to(&fb), fb.relative_to(&fa)];
    let walk = |grads: &mut Vec<Vector3<f64>>| {
        let band = band_of(
            &sphere,
            &cube,
            &rels,
            [1e-6; 2],
            2e-4,
            SpringShape {
                eps3: 1e-4,
                margin: 0.0,
            },
            BandWork {
                keep_terms: usize::MAX,
                scratch: &mut Scratch::default(),
                grads: Some(grads),
                memo: None,
            },
        );
        (band.entries.len(), band.evaluated)
    };
    let (mut fresh, mut after) = (Vec::new(), vec![Vector3::new(7.0, 8.0, 9.0)]);
    let (n, evaluated) = walk(&mut fresh);
    assert!(
        evaluated > n && n > 10,
        "{evaluated} evaluated, {n} in the band"
    );
    assert_eq!(walk(&mut after).0, n);
    assert_eq!(fresh.len(), n);
    assert_eq!(after[0], Vector3::new(7.0, 8.0, 9.0));
    assert_eq!(&after[1..], &fresh[..]);
}

#[test]
fn a_pairs_memory_grows_with_its_two_clouds_not_their_product() {
    // Random pairs of spheres and boxes, sampled from 1.5 to 6 mm, overlapping or apart, at
    // sharp to wide ε1 (a wide softmax makes every plane relevant at every point), walked with
    // kept candidates over a few small motions: the band's entries are at most I1 + I2, its
    // kept terms at most TERMS_PER_POINT (I1 + I2) plus one point's relevant set, and what the
    // pair keeps at most 8 kB per point (CANDIDATES_PER_POINT candidates of 28 bytes, doubled
    // by the spare buffers and the vectors' growth, on each side) plus 1 MB.
    let mut s = 29u64;
    let mut widest = 0.0f64;
    for case in 0..12 {
        let shape = |s: &mut u64| {
            let size = 0.01 + 0.03 * lcg(s).abs();
            let shape = if lcg(s) > 0.0 {
                Shape::Sphere { radius: size }
            } else {
                Shape::Box {
                    half: Vector3::new(size, 0.7 * size, 1.2 * size),
                }
            };
            Collider::Aopc(shape.sample(0.0015 + 0.0045 * lcg(s).abs()))
        };
        let (a, b) = (shape(&mut s), shape(&mut s));
        let eps1 = [1e-7, 1e-5, 1e-4][case % 3];
        let (n1, n2) = (a.len(), b.len());
        let axis = nalgebra::Unit::new_normalize(vec3(&mut s));
        let start = vec3(&mut s) * 0.02 + Vector3::new(0.0, 0.0, 0.02);
        let drift = vec3(&mut s) * 2e-4;
        let mut kept = CandidateMemo::default();
        for step in 0..6 {
            let t = step as f64;
            let fb = Frame {
                rotation: *nalgebra::Rotation3::from_axis_angle(&axis, 0.5 + 3e-3 * t).matrix(),
                origin: start + drift * t,
                ..Frame::identity()
            };
            let fa = Frame::<f64>::identity();
            let rels = [fa.relative_to(&fb), fb.relative_to(&fa)];
            let band = band_of(
                &a,
                &b,
                &rels,
                [eps1; 2],
                1e-3,
                SpringShape {
                    eps3: 1e-4,
                    margin: 0.0,
                },
                BandWork {
                    keep_terms: terms_budget(&a, &b),
                    scratch: &mut Scratch::default(),
                    grads: None,
                    memo: Some(&mut kept),
                },
            );
            let terms = TERMS_PER_POINT * (n1 + n2) + n1.max(n2);
            assert!(band.entries.len() <= n1 + n2, "case {case}");
            assert!(
                band.terms.len() <= terms,
                "case {case}: {} terms",
                band.terms.len()
            );
            let bytes = kept.heap_bytes();
            assert!(
                bytes <= 8192 * (n1 + n2) + (1 << 20),
                "case {case}: {bytes} bytes kept for {n1} + {n2} points"
            );
            if !band.entries.is_empty() {
                widest = widest.max(band.terms.len() as f64 / band.entries.len() as f64);
            }
        }
    }
    // The cases reach the regime the budgets are for.
    assert!(
        widest > TERMS_PER_POINT as f64,
        "{widest} terms per entry at most"
    );
}
