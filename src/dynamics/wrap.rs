//! A spatial tendon's segment wrapped around a sphere or a cylinder, as MuJoCo's tendons wrap
//! them (docs/mjcf.md, "Spatial tendons").
//!
//! Between two sites `x₀`, `x₁` a wrapping geom bends the path: from `x₀` straight to a point
//! `t₀` where the path meets the geom's surface tangentially, along the surface to `t₁`, and
//! straight on to `x₁`. Everything is worked out in the geom's frame:
//! - a sphere's path lies in the plane through its centre and the two sites (or, where they
//!   are in line with the centre, a plane through that line), a cylinder's in its cross-section
//!   (the plane normal to its axis), as a circle of the geom's radius;
//! - the path wraps when the straight segment between the two points, seen in that plane,
//!   comes within the radius of the centre; with a side site, also when it passes on the other
//!   side of the centre from the side site (the tendon then goes round the side site's way);
//! - the tangent points are those of the two tangent lines from each point to the circle that
//!   make a path round one side: of the two sides, the one whose tangent points' mean direction
//!   is nearer the side site's, or without one the one with the shorter chord; a side whose two
//!   straight pieces cross each other is never taken, and where the chosen one's cross the
//!   path does not wrap;
//! - on a cylinder the path rises along the axis in proportion to the distance covered in the
//!   cross-section (a helix on the surface), so its unrolled path is straight.
//!
//! With a side site inside the geom the path instead touches the circle at one point and
//! reflects there (equal angles with the normal), unless the straight segment already passes
//! through the circle: the point is found by Newton's method on its angle.
//!
//! The tangent points are where a stationary path meets the surface, so the length's gradient
//! with respect to the sites and to the geom's pose is carried by the straight pieces alone (the
//! envelope theorem): the tendon pulls on `x₀` and `x₁` along their pieces, and on the geom's
//! body at `t₀` and `t₁`, as if the tangent points were sites of that body (MuJoCo's tendon
//! Jacobian). The length is continuous and continuously differentiable where wrapping starts.

use crate::scalar::{c, Scalar};
use nalgebra::{Isometry3, Matrix3, Vector2, Vector3};

/// What a segment wraps around.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WrapShape {
    /// A sphere about the geom's origin.
    Sphere,
    /// An infinite cylinder about the geom's z axis.
    Cylinder,
}

/// A wrapping geom between a segment's two sites.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wrap {
    /// The geom's body.
    pub body: usize,
    /// The geom's pose in its body's frame.
    pub pose: Isometry3<f64>,
    /// Sphere or cylinder.
    pub shape: WrapShape,
    /// Its radius (m).
    pub radius: f64,
    /// The side site, if any: its body and its point in that body's frame.
    pub side: Option<(usize, Vector3<f64>)>,
}

/// A wrapped path in the geom's frame: the two points where it meets the surface (equal for
/// the inside wrap) and the length along the surface between them.
pub struct Wrapped<T> {
    /// `t₀` and `t₁`, in the geom's frame.
    pub points: [Vector3<T>; 2],
    /// The length along the surface (m).
    pub arc: T,
}

/// The smallest lengths the wrap computes with (MuJoCo's `mjMINVAL`).
const TINY: f64 = 1e-15;

/// The wrapped path between `p0` and `p1` (the sites in the geom's frame), with the side site
/// `side` in the same frame; `None` where the path does not wrap.
pub fn wrap<T: Scalar>(
    shape: WrapShape,
    radius: f64,
    p0: &Vector3<T>,
    p1: &Vector3<T>,
    side: Option<&Vector3<T>>,
) -> Option<Wrapped<T>> {
    if p0.norm().re() < TINY || p1.norm().re() < TINY {
        return None;
    }
    // The plane of the circle: two orthonormal axes.
    let (ax, ay): (Vector3<T>, Vector3<T>) = match shape {
        WrapShape::Cylinder => (Vector3::x().map(c), Vector3::y().map(c)),
        WrapShape::Sphere => {
            let ax = p0.normalize();
            let mut normal = p0.cross(p1);
            if normal.norm().re() < TINY {
                // The sites in line with the centre: any plane through that line; this one
                // leaves out the axis `ax` is most along.
                let r = ax.map(|x| x.re().abs());
                let i = if r.y > r.x && r.y > r.z {
                    1
                } else if r.z > r.x && r.z > r.y {
                    2
                } else {
                    0
                };
                let mut other = Vector3::from_element(T::one());
                other[i] = T::zero();
                normal = ax.cross(&other);
            }
            let normal = normal.normalize();
            (ax, normal.cross(&ax).normalize())
        }
    };
    let flat = |p: &Vector3<T>| Vector2::new(p.dot(&ax), p.dot(&ay));
    let (d0, d1) = (flat(p0), flat(p1));
    let inside_side = side.filter(|s| s.norm().re() < radius);
    let (pts, mut arc) = match inside_side {
        Some(_) => {
            let t = reflect(&d0, &d1, radius)?;
            ([t, t], T::zero())
        }
        None => {
            // A side site over the centre gives no direction: the plane's first axis then
            // (MuJoCo normalizes a zero vector to it).
            let sd = side.map(|s| {
                let f = flat(s);
                if f.norm().re() < TINY {
                    Vector2::new(c::<T>(radius), T::zero())
                } else {
                    f.normalize() * c::<T>(radius)
                }
            });
            circle(&d0, &d1, sd.as_ref(), radius)?
        }
    };
    let lift = |t: &Vector2<T>| ax * t.x + ay * t.y;
    let mut points = [lift(&pts[0]), lift(&pts[1])];
    if shape == WrapShape::Cylinder {
        // Rise along the axis in proportion to the distance covered in the cross-section.
        let l0 = (d0 - pts[0]).norm();
        let l1 = (d1 - pts[1]).norm();
        let total = l0 + arc + l1;
        let rise = p1.z - p0.z;
        points[0].z = p0.z + rise * l0 / total;
        points[1].z = p0.z + rise * (l0 + arc) / total;
        let h = points[1].z - points[0].z;
        arc = (arc * arc + h * h).sqrt();
    }
    Some(Wrapped { points, arc })
}

/// Whether the 2D segments `a0 a1` and `b0 b1` cross (each within its ends).
fn crossing<T: Scalar>(a0: &Vector2<T>, a1: &Vector2<T>, b0: &Vector2<T>, b1: &Vector2<T>) -> bool {
    let (a0, a1, b0, b1) = (
        a0.map(|x| x.re()),
        a1.map(|x| x.re()),
        b0.map(|x| x.re()),
        b1.map(|x| x.re()),
    );
    let (da, db) = (a1 - a0, b1 - b0);
    let det = db.y * da.x - db.x * da.y;
    if det.abs() < TINY {
        return false;
    }
    let off = a0 - b0;
    let s = (db.x * off.y - db.y * off.x) / det;
    let u = (da.x * off.y - da.y * off.x) / det;
    (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&u)
}

/// The outside wrap in the circle's plane: tangent points and arc length, or `None`.
#[allow(clippy::type_complexity)]
fn circle<T: Scalar>(
    d0: &Vector2<T>,
    d1: &Vector2<T>,
    side: Option<&Vector2<T>>,
    radius: f64,
) -> Option<([Vector2<T>; 2], T)> {
    let r2 = radius * radius;
    let (l0, l1) = (d0.norm_squared(), d1.norm_squared());
    if l0.re() < r2 || l1.re() < r2 || radius < TINY {
        return None;
    }
    let dif = d1 - d0;
    let dd = dif.norm_squared();
    if dd.re() < TINY {
        return None;
    }
    // The segment's point nearest the centre: it wraps when that is within the radius, or on
    // the far side from the side site.
    let a = (-(dif.dot(d0)) / dd).re().clamp(0.0, 1.0);
    let near = d0 + dif * c::<T>(a);
    if near.norm_squared().re() > r2 && side.is_none_or(|s| s.dot(&near).re() >= 0.0) {
        return None;
    }
    let (s0, s1) = ((l0 - r2).sqrt(), (l1 - r2).sqrt());
    let perp = |p: &Vector2<T>| Vector2::new(p.y, -p.x);
    let r = c::<T>(radius);
    // The two sides: k = +1 and -1.
    let sides = [1.0, -1.0].map(|k| {
        let t0 = (d0 * c::<T>(r2) + perp(d0) * (r * s0 * k)) / l0;
        let t1 = (d1 * c::<T>(r2) - perp(d1) * (r * s1 * k)) / l1;
        let good = if crossing(d0, &t0, d1, &t1) {
            -1e4
        } else {
            match side {
                Some(s) => (t0 + t1).normalize().dot(s).re(),
                None => -(t0 - t1).norm_squared().re(),
            }
        };
        (t0, t1, good)
    });
    let i = if sides[0].2 > sides[1].2 { 0 } else { 1 };
    let (t0, t1, _) = sides[i];
    if crossing(d0, &t0, d1, &t1) {
        return None;
    }
    // The angle from t0 to t1 the short way, the long way where the side goes round.
    let cross = t0.y * t1.x - t0.x * t1.y;
    let angle = cross.abs().atan2(t0.dot(&t1));
    let long = (cross.re() > 0.0 && i == 1) || (cross.re() < 0.0 && i == 0);
    let angle = if long {
        c::<T>(2.0 * std::f64::consts::PI) - angle
    } else {
        angle
    };
    Some(([t0, t1], angle * radius))
}

/// The inside wrap: the point of the circle where the path from `d0` to `d1` touches it and
/// reflects, or `None` where the straight segment passes through the circle (or an end is
/// within it): at the angle `ψ = θ - asin(A sin θ)` from the first end's direction (turning
/// towards the second; the roles swap where the second is clockwise of the first), where the
/// half-turn `θ` of the reflection solves `asin(A sin θ) + asin(B sin θ) - 2θ + G = 0`,
/// `A = r/|d0|`, `B = r/|d1|`, `G` the angle the two ends make at the centre.
fn reflect<T: Scalar>(d0: &Vector2<T>, d1: &Vector2<T>, radius: f64) -> Option<Vector2<T>> {
    let (n0, n1) = (d0.norm(), d1.norm());
    if n0.re() <= radius || n1.re() <= radius || radius < TINY || n0.re() < TINY || n1.re() < TINY {
        return None;
    }
    let dif = d1 - d0;
    let dd = dif.norm_squared();
    if dd.re() > TINY {
        let a = -(dif.dot(d0)) / dd;
        if a.re() > 0.0 && a.re() < 1.0 && (d0 + dif * a).norm().re() <= radius {
            return None;
        }
    }
    let r = c::<T>(radius);
    let (a, b) = (r / n0, r / n1);
    let cos_g = (n0 * n0 + n1 * n1 - dd) / (n0 * n1 * 2.0);
    let mid = || ((d0 + d1) * c::<T>(0.5)).normalize() * r;
    if cos_g.re() < -1.0 + TINY {
        return None;
    }
    if cos_g.re() > 1.0 - TINY {
        return Some(mid());
    }
    let g = cos_g.acos();
    // The reflection's half-turn θ (z = sin θ) solves f(θ) = asin(A sin θ) + asin(B sin θ)
    // - 2θ + G = 0 on [0, π/2], where f(0) = G > 0 and f falls; in θ rather than z, f stays
    // well conditioned up to grazing (θ = π/2, where the slope in z is infinite). Newton's
    // method kept inside the bracket (bisecting where a step would leave it), to the last
    // bits, then one step more for the dual parts. Where f(π/2) ≥ 0 the path grazes: θ = π/2.
    let f = |t: T| (a * t.sin()).asin() + (b * t.sin()).asin() - t * 2.0 + g;
    let slope = |t: T| {
        let s2 = t.sin() * t.sin();
        t.cos() * (a / (-(s2 * a * a) + 1.0).sqrt() + b / (-(s2 * b * b) + 1.0).sqrt()) - 2.0
    };
    let half_pi = std::f64::consts::FRAC_PI_2;
    let mut theta = c::<T>(half_pi);
    if f(theta).re() < 0.0 {
        let (mut lo, mut hi) = (0.0, half_pi);
        let mut done = false;
        for _ in 0..200 {
            let (ft, dt) = (f(theta), slope(theta));
            if ft.re() > 0.0 {
                lo = theta.re();
            } else {
                hi = theta.re();
            }
            let step = theta - ft / dt;
            theta = if dt.re() < 0.0 && step.re() >= lo && step.re() <= hi {
                step
            } else {
                c::<T>(0.5 * (lo + hi))
            };
            if done {
                break;
            }
            done = ft.re().abs() <= 1e-15 || hi - lo <= 1e-15;
        }
    }
    let z = theta.sin();
    let (from, other) = if (d0.x * d1.y - d0.y * d1.x).re() > 0.0 {
        (d0, a)
    } else {
        (d1, b)
    };
    let psi = theta - (other * z).asin();
    let u = from.normalize();
    let (s, co) = (psi.sin(), psi.cos());
    Some(Vector2::new(u.x * co - u.y * s, u.x * s + u.y * co) * r)
}

/// The geom's frame in world coordinates from its body's rotation and origin.
pub fn geom_frame<T: Scalar>(
    body_rotation: &Matrix3<T>,
    body_origin: &Vector3<T>,
    pose: &Isometry3<f64>,
) -> (Matrix3<T>, Vector3<T>) {
    let rot = body_rotation * pose.rotation.to_rotation_matrix().matrix().map(c::<T>);
    let origin = body_origin + body_rotation * pose.translation.vector.map(c::<T>);
    (rot, origin)
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::{first_derivative, Dual64};

    /// A sphere of radius 1, sites at (-2, 0.1, 0) and (2, 0.1, 0): tangents of length
    /// √(|p|² - 1) and the arc between them; its derivative along a site's motion is that of the straight
    /// piece (the envelope theorem).
    #[test]
    fn a_sphere_wrap_has_tangent_pieces_and_the_pieces_carry_the_gradient() {
        let len = |y: Dual64| {
            let p0 = Vector3::new(Dual64::from(-2.0), y, Dual64::from(0.0));
            let p1 = Vector3::new(2.0, 0.1, 0.0).map(Dual64::from);
            let w = wrap(WrapShape::Sphere, 1.0, &p0, &p1, None).expect("wraps");
            (p0 - w.points[0]).norm() + w.arc + (p1 - w.points[1]).norm()
        };
        let (l, dl) = first_derivative(len, 0.1);
        let p0 = Vector3::new(-2.0, 0.1, 0.0);
        let p1 = Vector3::new(2.0, 0.1, 0.0);
        let w = wrap::<f64>(WrapShape::Sphere, 1.0, &p0, &p1, None).unwrap();
        for (p, t) in [(p0, w.points[0]), (p1, w.points[1])] {
            assert!((t.norm() - 1.0).abs() < 1e-12, "on the surface");
            assert!(((p - t).dot(&t)).abs() < 1e-12, "tangent");
            assert!(((p - t).norm() - (p.norm_squared() - 1.0).sqrt()).abs() < 1e-9);
        }
        assert!(l > 2.0 * 3f64.sqrt() && l < 2.0 * 3f64.sqrt() + std::f64::consts::PI);
        let u = (p0 - w.points[0]).normalize();
        assert!(
            (dl - u.y).abs() < 1e-9,
            "dL/dy0 {dl} vs the piece's {}",
            u.y
        );
        let h = 1e-6;
        let fd = (len(Dual64::from(0.1 + h)).re - len(Dual64::from(0.1 - h)).re) / (2.0 * h);
        assert!((fd - dl).abs() < 1e-7, "{fd} vs {dl}");
    }

    /// A cylinder's side site on its axis has no direction in the cross-section: the wrap takes
    /// the plane's first axis, as a side site along it would give, and stays finite.
    #[test]
    fn a_side_site_on_the_axis_picks_the_first_axis() {
        let (p0, p1) = (Vector3::new(-2.0, 0.1, 0.3), Vector3::new(2.0, 0.1, -0.2));
        let on_axis = wrap::<f64>(
            WrapShape::Cylinder,
            1.0,
            &p0,
            &p1,
            Some(&Vector3::new(0.0, 0.0, 3.0)),
        );
        let along_x = wrap::<f64>(
            WrapShape::Cylinder,
            1.0,
            &p0,
            &p1,
            Some(&Vector3::new(1.5, 0.0, 0.0)),
        );
        let (a, b) = (on_axis.expect("wraps"), along_x.expect("wraps"));
        assert!(a.arc.is_finite() && a.arc == b.arc && a.points == b.points);
    }
}
