//! The lower bounds over a query region and the covering argument, against brute force.

use super::*;

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
