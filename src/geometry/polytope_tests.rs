//! Tests of the bounding polytope and its floor (`polytope.rs`).
use super::*;
use crate::geometry::Shape;
use num_dual::Dual64;

/// The polytope of a cloud's quad mesh, with the floor `kind`.
fn polytope(s: &crate::geometry::Aopc, kind: FloorKind) -> Polytope {
    Polytope::of(&s.points, &s.vertices, &s.faces, &s.reach, kind).expect("a quad mesh")
}

fn boxed() -> crate::geometry::Aopc {
    Shape::Box {
        half: Vector3::new(0.05, 0.03, 0.02),
    }
    .sample(0.01)
}

/// A point drawn from the 20 cm cube around the box above.
fn around_the_box(state: &mut u64) -> Vector3<f64> {
    let mut draw = || 0.2 * crate::geometry::lcg(state);
    Vector3::new(draw(), draw(), draw())
}

/// The exact signed distance of the box above.
fn box_sdf(x: &Vector3<f64>) -> f64 {
    let q = x.abs() - Vector3::new(0.05, 0.03, 0.02);
    q.map(|v| v.max(0.0)).norm() + q.max().min(0.0)
}

#[test]
fn the_floor_lies_below_the_surface_everywhere_and_margin_below_near_it() {
    let s = boxed();
    for kind in [FloorKind::Margin, FloorKind::Tight] {
        let p = polytope(&s, kind);
        assert!(
            p.cover() > 0.004 && p.cover() < 0.0075,
            "cover {}",
            p.cover()
        );
        let mut state = 7u64;
        for _ in 0..2000 {
            let x = around_the_box(&mut state);
            let mut f = p.floor(&x);
            let (b, _) = f.value();
            let sdf = box_sdf(&x);
            assert!(
                b <= sdf - p.margin * p.cover() + 1e-12,
                "{kind:?} {x:?}: floor {b} sdf {sdf}"
            );
            assert!(
                f.lower() <= b + 1e-15 && b <= f.upper + 1e-15,
                "bounds of b"
            );
        }
    }
}

#[test]
fn the_plane_values_are_the_directions_dot_products_to_the_bit() {
    // `u_kᵀx - h_k` summed term by term over all three components, as the definition
    // reads, against the shared products of `plane_values`: the same numbers at points of
    // every octant, on the axes and at the origin.
    let s = boxed();
    let p = polytope(&s, FloorKind::Margin);
    let mut state = 11u64;
    let mut points: Vec<Vector3<f64>> = (0..500)
        .map(|_| around_the_box(&mut state) * 1e3f64.powf(crate::geometry::lcg(&mut state)))
        .collect();
    points.extend([
        Vector3::zeros(),
        Vector3::x(),
        -Vector3::y(),
        Vector3::z() * 1e-300,
    ]);
    for x in points {
        let values = p.plane_values(&x);
        let mut top = f64::NEG_INFINITY;
        for (k, u) in AXES.iter().enumerate() {
            let d = u[0] * x.x + u[1] * x.y + u[2] * x.z;
            assert_eq!(values[k], d - p.support[k], "+u_{k} at {x:?}");
            assert_eq!(values[13 + k], -d - p.support[13 + k], "-u_{k} at {x:?}");
            top = top.max(d - p.support[k]).max(-d - p.support[13 + k]);
        }
        // The upper bound's running maxima give the largest value, less the margin.
        assert_eq!(p.upper(&x), top - 1.5 * p.cover, "upper bound at {x:?}");
        // The axes' bound lies below the floor's own lower bound, and so below the floor.
        let mut floor = p.floor(&x);
        let by_axes = p.floor_by_axes(&x);
        assert!(by_axes <= floor.lower(), "axes {by_axes} at {x:?}");
        assert!(by_axes <= floor.value().0, "axes {by_axes} at {x:?}");
    }
}

#[test]
fn a_reading_near_the_truth_is_left_bit_for_bit_and_one_far_below_is_raised() {
    let s = boxed();
    let p = polytope(&s, FloorKind::Margin);
    // Beside the top face's edge, 4 cm out in its plane: the top plane reads 0.
    let x = Vector3::new(0.09, 0.0, 0.02);
    let mut f = p.floor(&x);
    let (b, _) = f.value();
    assert!(b > 0.02, "the polytope proves 4 cm less the margin: {b}");
    let (raised, s) = f.raise(0.0);
    assert!(raised >= b && raised < b + 1e-6 && s > 0.99);
    // The true distance, or anything within half a cover radius below it, is untouched.
    for phi in [0.04, 0.04 - 0.5 * p.cover()] {
        assert_eq!(f.raise(phi), (phi, 0.0));
    }
}

/// The box above with its +x face as one face (6 × 4 cm, cover radius 3.6 cm), its other
/// faces as sampled (cover radius 7.1 mm), and the index of one of those.
fn capped(kind: FloorKind) -> (Polytope, usize) {
    let mut s = boxed().retain(|p| p.x < 0.0499);
    let v = |y: f64, z: f64| Vector3::new(0.05, y, z);
    s.push_quad([
        v(-0.03, -0.02),
        v(0.03, -0.02),
        v(0.03, 0.02),
        v(-0.03, 0.02),
    ]);
    let p = polytope(&s, kind);
    (p, 0)
}

#[test]
fn a_plane_is_raised_to_its_own_faces_floor() {
    let (p, k) = capped(FloorKind::Margin);
    assert!((p.cover() - 0.036).abs() < 1e-3, "cover {}", p.cover());
    let rk = p.cover_of(k);
    assert!(
        (rk - 0.005 * 2f64.sqrt()).abs() < 1e-9,
        "its own cover radius {rk}"
    );
    // Beside the top face's edge, 4 cm out: the polytope proves 4 cm, less 5.4 cm for
    // the cloud, less 1.1 cm for a sampled face's plane, which reads 0 there.
    let x = Vector3::new(0.09, 0.0, 0.02);
    let mut f = p.floor(&x);
    let (b, _) = f.value();
    assert!(b < -0.01 && b > -0.02, "the cloud's floor {b}");
    let (raised, s, _) = f.raise_plane(0.0, k);
    assert!(raised > 0.04 - 1.5 * rk - 1e-3 && s > 0.99, "{raised}");
    // The truth, or anything within half its face's cover radius below it, is left as it
    // is by the plane's floor (the cloud's reaches that far only within 1.8 cm).
    for phi in [0.04, 0.04 - 0.5 * rk] {
        assert_eq!(f.raise_plane(phi, k), (phi, 0.0, Vector3::zeros()));
    }
    // Every plane's floor lies above the cloud's lower bound lifted by `lift_of` (what the
    // spring bounds and the reach proofs take), and below the surface less its margin; under
    // the tight floor too (no margin, a quarter the planes' temperature).
    for kind in [FloorKind::Margin, FloorKind::Tight] {
        let (p, _) = capped(kind);
        let mut state = 11u64;
        for _ in 0..300 {
            let x = around_the_box(&mut state);
            let mut f = p.floor(&x);
            for j in 0..p.covers.len() {
                let (bj, _) = f.plane_floor(j);
                assert!(
                    bj >= f.lower() + p.lift_of(j),
                    "{kind:?} {x:?}, plane {j}: {bj}"
                );
                assert!(
                    bj <= box_sdf(&x) - p.margin * p.cover_of(j) + 1e-12,
                    "{kind:?} {x:?}, plane {j}"
                );
            }
        }
    }
    let mut f = p.floor(&x);
    // A plane the polytope does not know gets the cloud's margin, at the planes' sharper
    // temperature: at least the cloud's floor, and within `T ln 26` of it.
    let (cloud, _) = f.raise(-0.05);
    let (unknown, _, _) = f.raise_plane(-0.05, usize::MAX);
    assert!(unknown >= cloud && unknown <= cloud + p.temperature() * 26f64.ln() + 1e-12);
}

#[test]
fn the_raised_reading_and_floor_match_central_differences() {
    let s = boxed();
    let p = polytope(&s, FloorKind::Margin);
    // The cloud's floor, and a plane's own on the capped box (a 7.1 mm face, whose floor
    // lies 4 cm above its cloud's): each where a reading that depends on x too is near it
    // (the soft part).
    let (capped, k) = capped(FloorKind::Margin);
    let x0 = Vector3::new(0.061, 0.033, 0.018);
    // The tight floor (no margin, a quarter the planes' temperature): a plane's reading at its
    // floor beside the box's edge, where its +x, +y and x+y planes read within two of that
    // temperature of each other.
    let tight = polytope(&s, FloorKind::Tight);
    let corner = Vector3::new(0.0501, 0.0301, 0.0);
    let (b_tight, _) = tight.floor(&corner).plane_floor(0);
    let cases = [
        (&p, None, 0.0609, x0),
        (&capped, Some(k), 0.0609, x0),
        (&tight, Some(0), corner.x - b_tight, corner),
    ];
    let h = 1e-7;
    for ((p, plane, at_x, x0), dir) in cases.into_iter().flat_map(|c| (0..3).map(move |d| (c, d))) {
        let at = |e: f64| {
            let mut x = x0.map(Dual64::from);
            x[dir] += Dual64::new(e, 1.0);
            let mut f = p.floor(&x);
            let phi = x[0] - Dual64::from(at_x);
            let ((b, g), (r, s)) = match plane {
                Some(k) => {
                    let (r, s, g) = f.raise_plane(phi, k);
                    let (b, gk) = f.plane_floor(k);
                    assert_eq!(g, gk);
                    ((b, g), (r, s))
                }
                None => (f.value(), f.raise(phi)),
            };
            assert!(s > 0.01 && s < 0.99, "the soft part: {s}");
            (b, g[dir], r)
        };
        let (b, g, r) = at(0.0);
        let fd_b = (at(h).0.re - at(-h).0.re) / (2.0 * h);
        let fd_r = (at(h).2.re - at(-h).2.re) / (2.0 * h);
        assert!((b.eps - fd_b).abs() < 1e-6, "db: {} vs {fd_b}", b.eps);
        assert!((g - fd_b).abs() < 1e-6, "gradient: {g} vs {fd_b}");
        assert!((r.eps - fd_r).abs() < 1e-6, "dφ': {} vs {fd_r}", r.eps);
    }
}
