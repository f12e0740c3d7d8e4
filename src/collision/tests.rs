//! Tests of the collision bounds and the band walk against the naive evaluation.

use super::bounds::*;
use super::reach::{cloud_beyond_with, seed_within};
use super::*;
use crate::geometry::Shape;

use crate::geometry::lcg;

fn vec3(s: &mut u64) -> Vector3<f64> {
    Vector3::new(lcg(s), lcg(s), lcg(s))
}

/// A point of the region: a random offset in the ball, projected into the slab along `m`.
fn sample_region(q: &QueryRegion, s: &mut u64) -> Vector3<f64> {
    loop {
        let y = vec3(s) * q.radius;
        let h = q.m.dot(&y);
        if y.norm() <= q.radius && h >= q.lo && h <= q.hi {
            return q.centre + y;
        }
        // Move it into the slab along m, keeping it in the ball when possible.
        let hc = h.clamp(q.lo, q.hi);
        let y2 = y + q.m * (hc - h);
        if y2.norm() <= q.radius {
            return q.centre + y2;
        }
    }
}

#[test]
fn min_lin_is_the_minimum_over_the_ball_cut_by_the_slab() {
    let mut s = 7u64;
    for _ in 0..2000 {
        let r = 0.01 + lcg(&mut s).abs();
        let m = vec3(&mut s).normalize();
        let (a, b) = (lcg(&mut s) * r, lcg(&mut s) * r);
        let q = QueryRegion {
            centre: vec3(&mut s),
            radius: r,
            m,
            lo: a.min(b),
            hi: a.max(b),
        };
        let n = vec3(&mut s) * 2.0;
        let lower = q.min_lin(&n);
        // A lower bound at sampled points of the region...
        for _ in 0..50 {
            let x = sample_region(&q, &mut s);
            assert!(
                n.dot(&(x - q.centre)) >= lower,
                "{} < {lower}",
                n.dot(&(x - q.centre))
            );
        }
        // ...attained (to rounding) at the minimiser of the proof: s* clamped, then the
        // perpendicular part of the ball's extent against n.
        let alpha = n.dot(&m);
        let perp = n - m * alpha;
        let sc = (-alpha * r / n.norm()).clamp(q.lo, q.hi);
        let u = if perp.norm() > 0.0 {
            -perp.normalize() * (r * r - sc * sc).max(0.0).sqrt()
        } else {
            Vector3::zeros()
        };
        let y = m * sc + u;
        assert!(y.norm() <= r * (1.0 + 1e-12) && (m.dot(&y) - sc).abs() <= 1e-12 * r);
        assert!(
            (n.dot(&y) - lower).abs() <= 1e-9 * n.norm() * r,
            "{} vs {lower}",
            n.dot(&y)
        );
    }
    // The whole ball: -r|n|.
    let q = QueryRegion::ball(Vector3::zeros(), 0.5);
    let n = Vector3::new(0.3, -0.4, 1.2);
    assert!((q.min_lin(&n) + 0.5 * n.norm()).abs() < 1e-12);
}

#[test]
fn lower_distance_to_a_convex_set_holds_over_the_region() {
    // A point (a sphere's centre) and a segment (a capsule's spine): the bound from the set's
    // point nearest the centre is below the distance of every sampled point of the region, and
    // zero when the centre is in the set.
    let mut s = 11u64;
    let nearest_on = |a: &Vector3<f64>, b: &Vector3<f64>, x: &Vector3<f64>| {
        let d = b - a;
        let t = if d.norm_squared() > 0.0 {
            ((x - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        a + d * t
    };
    for k in 0..1000 {
        let r = 0.01 + 0.3 * lcg(&mut s).abs();
        let m = vec3(&mut s).normalize();
        let (lo, hi) = (lcg(&mut s) * r, lcg(&mut s) * r);
        let q = QueryRegion {
            centre: vec3(&mut s),
            radius: r,
            m,
            lo: lo.min(hi),
            hi: lo.max(hi),
        };
        // Every other case a segment, else a point.
        let a = vec3(&mut s) * 0.5;
        let b = if k % 2 == 0 {
            a + vec3(&mut s) * 0.4
        } else {
            a
        };
        let bound = q.lower_distance_to(&nearest_on(&a, &b, &q.centre));
        for _ in 0..40 {
            let x = sample_region(&q, &mut s);
            let d = (x - nearest_on(&a, &b, &x)).norm();
            assert!(
                d >= bound - 1e-12,
                "case {k}: distance {d} below the bound {bound}"
            );
        }
    }
    let q = QueryRegion::ball(Vector3::new(0.1, 0.0, 0.0), 0.05);
    assert_eq!(q.lower_distance_to(&q.centre.clone()), 0.0);
    // A whole ball of radius 0.05 at 0.1 from a point: 0.05 exactly (to rounding).
    assert!((q.lower_distance_to(&Vector3::zeros()) - 0.05).abs() < 1e-12);
}

#[test]
fn cone_bound_is_a_lower_bound_of_every_plane_of_a_cluster_over_the_region() {
    // Curved (sphere, cylinder) and flat (box) clusters at several levels, regions near and
    // far, thin (a slab) and full balls.
    let mut s = 11u64;
    for shape in [
        Shape::Sphere { radius: 0.05 },
        Shape::Box {
            half: Vector3::new(0.1, 0.06, 0.03),
        },
        Shape::Cylinder {
            radius: 0.04,
            half_length: 0.05,
        },
    ] {
        let cloud = shape.sample(0.004);
        let bvh = cloud.bvh();
        let (mut checked, mut behind) = (0, 0);
        for node in bvh.nodes.iter().filter(|n| n.count <= 64) {
            let r = 0.002 + 0.02 * lcg(&mut s).abs();
            let m = vec3(&mut s).normalize();
            let h = 0.3 * r * lcg(&mut s).abs();
            let q = QueryRegion {
                centre: node.centre + vec3(&mut s) * 0.1,
                radius: r,
                m,
                lo: -h,
                hi: h,
            };
            let bound = cone_bound(node, &q);
            if !bound.is_finite() {
                continue;
            }
            checked += 1;
            // The bound for a region behind the cluster's planes (`A < 0`), sharper than
            // Cauchy–Schwarz for a narrow cone.
            let w = q.centre - node.centre;
            let big_a = node.axis.dot(&w) + q.min_lin(&node.axis);
            let big_p = (w - node.axis * node.axis.dot(&w)).norm() + q.radius;
            if big_a < 0.0 && bound > -(big_a * big_a + big_p * big_p).sqrt() - node.support {
                behind += 1;
            }
            for _ in 0..20 {
                let x = sample_region(&q, &mut s);
                for k in node.start as usize..(node.start + node.count) as usize {
                    let v = bvh.normals[k].dot(&(x - bvh.points[k]));
                    assert!(v >= bound, "{v} < {bound}");
                }
            }
        }
        assert!(checked > 20, "{checked} clusters with a cone under 90°");
        assert!(
            behind > 10,
            "{behind} regions behind a cluster's planes with a narrow cone"
        );
    }
}

/// The covering argument against brute force: near a box's bottom edges, below the
/// bottom face, every point or cluster that `covered_out` / `cluster_covered` proves out
/// is irrelevant (`d_i - d_min > m1`) at sampled points of the ball wherever its plane is
/// at or below `need` (about 18,000 points and 2,600 clusters proven, 6 M checks). It
/// fails if the polygon check is loosened (the side face's points past the edge are then
/// "proven" out where they are nearest) or if the largest instead of the smallest height
/// over the set is taken; the covering radius has its own test below.
#[test]
fn the_covering_argument_proves_out_only_irrelevant_points() {
    let cloud = Shape::Box {
        half: Vector3::repeat(0.05),
    }
    .sample(0.002);
    let bvh = cloud.bvh();
    assert_eq!(bvh.patches.len(), 6);
    let m1 = bvh.log_terms * 1e-9;
    let dmin = |x: &Vector3<f64>| {
        bvh.points
            .iter()
            .map(|p| (x - p).norm_squared())
            .fold(f64::INFINITY, f64::min)
    };
    let mut s = 11u64;
    let (mut points_proven, mut clusters_proven, mut checked, mut outside) = (0, 0, 0, 0);
    for case in 0..300 {
        // A region below the bottom face (z = -0.05) by 1 to 20 mm, from 1 cm inside an
        // edge in y to 2 cm past it, 1 to 8 mm in radius (it may cross the face's plane);
        // every other one close to the edge and the face, where the side face's points
        // are nearest past the edge (there the polygon check is what refuses a proof).
        // Cases 3 and 4 reach past the face's edges, where the covering bound also charges
        // the distance to the polygon: near a corner (past both edges in part), and a
        // little past one edge, where the side face's first row is nearest and its planes
        // lie below `need` (proving it out there would be wrong).
        let (c, r) = match case % 5 {
            4 => (
                Vector3::new(
                    0.03 * lcg(&mut s),
                    -0.052 + 0.0015 * lcg(&mut s),
                    -0.06 - 0.005 * lcg(&mut s),
                ),
                0.0015 + 0.0005 * lcg(&mut s),
            ),
            3 => (
                Vector3::new(
                    -0.049 + 0.007 * lcg(&mut s),
                    -0.049 + 0.007 * lcg(&mut s),
                    -0.061 - 0.009 * lcg(&mut s),
                ),
                0.0045 + 0.0035 * lcg(&mut s),
            ),
            0 => (
                Vector3::new(
                    0.03 * lcg(&mut s),
                    -0.055 + 0.015 * lcg(&mut s),
                    -0.0605 - 0.0095 * lcg(&mut s),
                ),
                0.0045 + 0.0035 * lcg(&mut s),
            ),
            1 => (
                Vector3::new(
                    0.03 * lcg(&mut s),
                    -0.05 + 0.001 * lcg(&mut s),
                    -0.0512 - 0.0002 * lcg(&mut s),
                ),
                0.00095 + 0.00015 * lcg(&mut s),
            ),
            // Touching the face from below, at the edge: the side face's first row is
            // nearest there by less than the quads' reach `ρ`.
            _ => {
                let r = 0.0005 + 0.0003 * lcg(&mut s);
                (
                    Vector3::new(
                        0.03 * lcg(&mut s),
                        -0.0495 + 0.0005 * lcg(&mut s),
                        -0.05 - r * 1.0001,
                    ),
                    r,
                )
            }
        };
        let q = QueryRegion::ball(c, r);
        let (j, _) = bvh.nearest(&c);
        let Some(patch) = bvh.patch_of(j) else {
            continue;
        };
        let need = if case % 5 == 0 || case % 5 == 3 {
            0.004 * lcg(&mut s)
        } else {
            0.002 + 0.002 * lcg(&mut s)
        };
        let samples: Vec<Vector3<f64>> = (0..150).map(|_| sample_region(&q, &mut s)).collect();
        let dmins: Vec<f64> = samples.iter().map(dmin).collect();
        let mut verify = |k: usize| {
            let (pk, nk) = (bvh.points[k], bvh.normals[k]);
            for (x, dm) in samples.iter().zip(&dmins) {
                if nk.dot(&(x - pk)) <= need {
                    checked += 1;
                    assert!(
                        (x - pk).norm_squared() - dm > m1,
                        "point {k} relevant at {x:?} with its plane below need"
                    );
                }
            }
        };
        for (k, p) in bvh.points.iter().enumerate() {
            if (p - c).norm() > 0.03 {
                continue;
            }
            let v0 = bvh.normals[k].dot(&(c - p));
            let depth = patch.offset - patch.normal.dot(p) - 1e-12 * p.norm();
            if covered_out(patch, &c, r, &bvh.normals[k], need - v0, (depth, depth), m1) {
                points_proven += 1;
                outside += usize::from(c.x - r < -0.05 || c.y - r < -0.05);
                verify(k);
            }
        }
        for node in &bvh.nodes {
            if node.radius < 0.012
                && (node.centre - c).norm() < 0.03
                && cluster_covered(patch, node, &q, need, m1)
            {
                clusters_proven += 1;
                (node.start as usize..(node.start + node.count) as usize).for_each(&mut verify);
            }
        }
    }
    assert!(points_proven > 200 && clusters_proven > 20 && checked > 10_000 && outside > 100, "the test proves too little: {points_proven} points ({outside} from regions reaching past an edge), {clusters_proven} clusters, {checked} checks");
}

/// The covering radius matters: below a corner of a quad of a box's bottom face, at a
/// height `u`, a point at a depth `s` behind the face, with `s² + 2us` under the corner's
/// squared in-plane distance to the nearest point, is relevant there (its squared distance
/// within `M1 ε1` of the smallest), and `covered_out` must not prove it out (it would with
/// `ρ = 0`).
#[test]
fn the_covering_bound_keeps_a_point_nearer_than_the_quads_reach() {
    let cloud = Shape::Box {
        half: Vector3::repeat(0.05),
    }
    .sample(0.002);
    let bvh = cloud.bvh();
    let m1 = bvh.log_terms * 1e-9;
    let bottom = bvh
        .patches
        .iter()
        .find(|p| p.normal.z < -0.5)
        .expect("the bottom face's patch");
    let mut tested = 0;
    for (f, face) in cloud.faces.iter().enumerate() {
        if cloud.normals[f].z > -0.5 || tested >= 40 {
            continue;
        }
        let v = cloud.vertices[face[0] as usize];
        if v.x.abs() > 0.045 || v.y.abs() > 0.045 {
            continue; // an inner corner, away from the face's edges
        }
        tested += 1;
        let reach2 = bvh
            .points
            .iter()
            .filter(|p| p.z < -0.0499)
            .map(|p| (p.xy() - v.xy()).norm_squared())
            .fold(f64::INFINITY, f64::min);
        let u = 1e-4;
        // s² + 2us = 0.8 reach²
        let s = -u + (u * u + 0.8 * reach2).sqrt();
        let x = v - Vector3::z() * u;
        let pi = v + Vector3::z() * s;
        let dmin = bvh
            .points
            .iter()
            .map(|p| (x - p).norm_squared())
            .fold(f64::INFINITY, f64::min);
        assert!(
            (x - pi).norm_squared() - dmin < m1,
            "the construction: the point is relevant at x"
        );
        assert!(
            !covered_out(bottom, &x, 1e-9, &Vector3::z(), 1.0, (s, s), m1),
            "proven out although nearest, below corner {v:?}"
        );
    }
    assert_eq!(tested, 40);
}

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
            eps1,
            eps2,
            1e-4,
            usize::MAX,
            &mut Relevant::default(),
            None,
            None,
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
    // with the pair's kept candidates (`KeptCandidates`) and without: the same entries, Φ,
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
        let mut kept = KeptCandidates::default();
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
            let walk = |kept: Option<&mut KeptCandidates>| {
                band_of(
                    &sphere,
                    &cube,
                    &rels,
                    eps1,
                    eps2,
                    1e-4,
                    usize::MAX,
                    &mut Relevant::default(),
                    None,
                    kept,
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
            2.0 * eps1,
            eps2,
            1e-4,
            usize::MAX,
            &mut Relevant::default(),
            None,
            Some(&mut kept),
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
        let with = cloud_beyond_with(planes, q, &rot, &tr, t, 1e-5, true);
        let without = cloud_beyond_with(planes, q, &rot, &tr, t, 1e-5, false);
        assert_eq!(with, without, "case {case}: gap {gap}, threshold {t}");
        proven += with as usize;
        // (The allowance's `vmax` only widens it: 0 here, so these are surely within.)
        let seen = seed_within(
            planes,
            q.bvh(),
            &rot,
            &tr,
            t,
            1e-5,
            0.0,
            &mut Relevant::default(),
        );
        assert!(
            !(seen && with),
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
            1e-6,
            2e-4,
            1e-4,
            usize::MAX,
            &mut Relevant::default(),
            Some(grads),
            None,
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
        let mut kept = KeptCandidates::default();
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
                eps1,
                1e-3,
                1e-4,
                terms_budget(&a, &b),
                &mut Relevant::default(),
                None,
                Some(&mut kept),
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
