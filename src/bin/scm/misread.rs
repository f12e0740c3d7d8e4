//! `scm check`'s reading of each pair at the scene's initial pose against the surfaces its
//! clouds sample (docs/mjcf.md, "Contact on, against MuJoCo's spread"): a cloud sampled in
//! patches reads each query point against the plane of its nearest points, and near a face's
//! edge that plane passes beside the surface. The convex hull of a cloud's mesh vertices holds
//! its sampled surface (each triangle is a convex combination of its corners), so the largest
//! of the hull's face planes at a point bounds the point's distance from below; a reading well
//! under that bound, near enough to push, is a pair that pushes where its sampled points lie
//! outside the other body (robosuite's xArm7 under the margin: its base and link 1 read 1.36 mm
//! into each other, 0.2 mm apart). Under the tight floor (a mesh's, by default) no reading is
//! below that bound, and what is left to report is the push the law's `ε3` tail makes across a
//! gap where MuJoCo has no contact (the same pair: 11 N across its 0.2 mm).

use nalgebra::Vector3;
use scm::collision::{separation_band, Collider};
use scm::geometry::polytope::FloorKind;
use scm::geometry::TriMesh;
use scm::model::Model;

/// How far below its bound a reading must be to be reported (m).
const MISREAD: f64 = 1e-4;

/// The push across a gap worth a warning, as a depth of the pair's spring (m): as much as the
/// spring pushes 1 µm deep.
const TAIL: f64 = 1e-6;

/// How far out of a hull a cloud's point may lie for the hull to hold the cloud (m): rounding.
const HELD: f64 = 1e-9;

/// A plane `(n, h)`: `nᵀy ≤ h` inside, body frame.
type Plane = (Vector3<f64>, f64);

/// The face planes of the convex hull of a cloud's reach (a mesh's vertices, sampled in
/// patches, and the face corners of any geom joined to it), where the cloud has one and every
/// point of the cloud lies in that hull (a primitive's points on a curved face would not).
fn hull_planes(collider: &Collider) -> Option<Vec<Plane>> {
    let Collider::Aopc(cloud) = collider else {
        return None;
    };
    if cloud.reach.len() < 4 {
        return None;
    }
    let hull = TriMesh::convex_hull("the cloud's mesh vertices", &cloud.reach).ok()?;
    let planes: Vec<Plane> = (hull.triangles.iter())
        .map(|t| {
            let [a, b, c] = t.map(|i| hull.vertices[i as usize]);
            let n = (b - a).cross(&(c - a)).normalize();
            (n, n.dot(&a))
        })
        .collect();
    let holds = (cloud.points.iter()).all(|x| floor(&planes, x) <= HELD);
    holds.then_some(planes)
}

/// The largest plane value at `x`: at most `x`'s signed distance from the hull.
fn floor(planes: &[Plane], x: &Vector3<f64>) -> f64 {
    (planes.iter()).fold(f64::NEG_INFINITY, |m, (n, h)| m.max(n.dot(x) - h))
}

/// One warning per pair every query point of whose band lies outside the hull of the other
/// body's mesh vertices at the scene's initial pose (both bodies' clouds held by such hulls),
/// while a cloud of it has the margin and a point within ten `ε3` of the margin (where its
/// spring pushes) reads more than [`MISREAD`] nearer than its bound: the pair pushes where its
/// sampled points do not touch the other body (the band's points are samples: an edge between
/// them is not checked); or while both clouds have the tight floor, the least bound lies
/// beyond the pair's margin and within ten `ε3` of it, and the pair pushes more than
/// [`TAIL`] of its spring.
pub(super) fn misread_pairs(m: &Model) -> Vec<String> {
    let hulls: Vec<Option<Vec<Plane>>> = (m.colliders.iter())
        .map(|c| c.as_ref().and_then(hull_planes))
        .collect();
    if hulls.iter().all(Option::is_none) {
        return Vec::new();
    }
    let kin = m.tree.kinematics(&m.q0, &m.v0);
    let mut out = Vec::new();
    for p in &m.pairs {
        let (Some(a), Some(b)) = (&m.colliders[p.a], &m.colliders[p.b]) else {
            continue;
        };
        let (Some(hull_a), Some(hull_b)) = (&hulls[p.a], &hulls[p.b]) else {
            continue;
        };
        // Under the tight floor every plane's reading is floored at what the polytope proves,
        // which the band's entries (floored at the cloud's temperature) do not show: what is
        // left to report is the push across the gap.
        let tight = |c: &Collider| matches!(c, Collider::Aopc(s) if s.floor() == FloorKind::Tight);
        let tight = tight(a) && tight(b);
        let own = p.params(&m.contact);
        let (fa, fb) = (&kin.frames[p.a], &kin.frames[p.b]);
        let band = separation_band(a, fa, b, fb, own.eps1_sides(), own.eps2);
        let near = own.margin + 10.0 * own.eps3;
        // The least bound (how far apart the surfaces are at least), and the entry read most
        // below its bound: (reading, bound, query body, plane body).
        let mut apart = f64::INFINITY;
        let mut worst: Option<(f64, f64, usize, usize)> = None;
        for e in &band.entries {
            let (query, fq, fp, planes, [q, pl]) = match e.side {
                0 => (a, fa, fb, hull_b, [p.a, p.b]),
                _ => (b, fb, fa, hull_a, [p.b, p.a]),
            };
            let Collider::Aopc(cloud) = query else {
                continue;
            };
            let rel = fq.relative_to(fp);
            let x = rel.rotation * cloud.bvh().points[e.k as usize] + rel.translation;
            let bound = floor(planes, &x);
            apart = apart.min(bound);
            let below = bound - e.phi;
            if e.phi < near && below > MISREAD && worst.is_none_or(|w| below > w.1 - w.0) {
                worst = Some((e.phi, bound, q, pl));
            }
        }
        if apart <= 0.0 {
            continue;
        }
        let misread = worst.filter(|_| !tight);
        let force = || {
            scm::contact::pair_contact(a, fa, b, fb, &own)
                .on_a
                .force
                .norm()
        };
        let name = |i: usize| &m.tree.bodies[i].name;
        let at = format!(
            "pair {} - {} at the initial pose: every point of its band lies at least {:.3} mm outside the convex hull of the other body's mesh vertices (which holds that body's sampled surface)",
            name(p.a),
            name(p.b),
            apart * 1e3,
        );
        let pressing = || scm::contact::pair_pressing(a, fa, b, fb, &own);
        if let Some((phi, bound, q, pl)) = misread {
            let (force, pressing) = (force(), pressing());
            out.push(format!(
                "{at}, but a point of {} reads {:.3} mm from {}'s planes where it lies at least {:.3} mm outside that hull (a cloud's planes read past their faces' edges), and the pair pushes with {force:.3} N, its point forces adding up to {pressing:.3} N (its friction acts on at least that); the tight floor (a mesh's default, which the scene's scm_floor overrides) floors every plane's reading at what the other body's polytope proves, and a scm.eps3 well below the gap shortens the push across it (docs/mjcf.md, \"Contact on, against MuJoCo's spread\")",
                name(q),
                phi * 1e3,
                name(pl),
                bound * 1e3,
            ));
            continue;
        }
        let across = tight && apart > own.margin && apart < near;
        let force = if across { force() } else { 0.0 };
        if force > TAIL * own.stiffness {
            out.push(format!(
                "{at}, beyond the pair's margin of {:.3} mm, where MuJoCo makes no contact, yet the pair pushes with {force:.3} N across the gap, its point forces adding up to {:.3} N (its friction acts on at least that): the contact law's tail k ε3 s⁺(-d/ε3) at ε3 = {:.0e} m and k = {:.4e} N/m; a scm.eps3 a tenth of the gap or less shortens it (docs/mjcf.md, \"Contact on, against MuJoCo's spread\")",
                own.margin * 1e3,
                pressing(),
                own.eps3,
                own.stiffness,
            ));
        }
    }
    out
}
