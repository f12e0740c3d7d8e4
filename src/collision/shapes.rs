//! A side of a pair settled by the two clouds' shapes alone, before any node of either
//! hierarchy is walked: where the query cloud's points lie within known distances of a few
//! segments ([`crate::geometry::holders`]) and the plane cloud bounds its relevant planes in
//! closed form in the distance from its own segments (a sampled sphere, capsule or rounded
//! union: [`crate::geometry::radial`], [`crate::geometry::spine`], [`crate::geometry::rounded`]),
//! the distance between segments bounds from below the distance from every query point to the
//! plane cloud's segments, and with it every relevant plane. The same closed forms over one
//! region of query points ([`closed_forms_settle`], with a sampled box's face by face) are the
//! first thing every node test of the walks tries.
//!
//! Why: two limbs side by side whose bounding spheres overlap (gymnasium's humanoid, a lower
//! arm hanging beside a thigh) were proven out of reach by walking both hierarchies down to
//! single points at every forward (50 to 220 µs a proof, a quarter of the whole run), where
//! the limbs' segments alone show them centimetres apart (docs/performance.md).

use super::*;
use crate::geometry::holders::{holders, segment_distance, Holder};

/// Whether every plane of `planes` that can carry weight (within `m1`, m², of the nearest
/// one) exceeds `need` (m) at every point of the query cloud `query`, posed in the frame of
/// `planes` by `x = rot p + tr`, proven from the two clouds' certificates; `false` where
/// either has none or the bound does not clear `need`. (`need` as the band walk's node test
/// takes it, [`super::bounds::band_need`], which turns the bound on every relevant plane into
/// one on the SSDF.)
pub(super) fn shapes_settle(
    planes: &Aopc,
    query: &Aopc,
    rot: &Matrix3<f64>,
    tr: &Vector3<f64>,
    m1: f64,
    need: f64,
) -> bool {
    let pb = planes.bvh();
    if pb.radial.is_none() && pb.spine.is_none() && pb.rounded.is_none() {
        return false;
    }
    let posed = |h: Holder| Holder {
        start: rot * h.start + tr,
        end: rot * h.end + tr,
        reach: h.reach,
    };
    // The least distance from any query point to the segment `a`–`b`: every query point lies
    // within its holder's reach of the holder's segment. `None` without holders (nothing
    // then bounds where the points are).
    let lowest = |a: &Vector3<f64>, b: &Vector3<f64>| {
        holders(query.bvh())
            .map(|h| {
                let h = posed(h);
                let d = segment_distance(&h.start, &h.end, a, b);
                d - h.reach - 1e-12 * (h.reach + d)
            })
            .reduce(f64::min)
    };
    if let Some(r) = &pb.radial {
        return lowest(&r.centre, &r.centre).is_some_and(|s| r.plane_bound(s, m1) > need);
    }
    if let Some(s) = &pb.spine {
        return lowest(&s.start, &s.end).is_some_and(|lo| s.plane_bound(lo, m1) > need);
    }
    pb.rounded.as_ref().is_some_and(|u| {
        u.members
            .iter()
            .all(|m| lowest(&m.start, &m.end).is_some_and(|s| m.plane_bound(s, u.cover, m1) > need))
    })
}

/// The closed-form bounds of a sampled sphere, capsule, union of both or box
/// ([`super::bounds::aopc_exceeds`]): whether one of them settles the whole region over the margin `m1`.
pub(super) fn closed_forms_settle(
    s: &Aopc,
    q: &QueryRegion,
    t: f64,
    vmax: Option<f64>,
    m1: f64,
) -> bool {
    let bvh = s.bvh();
    let Some(v) = vmax else {
        return false;
    };
    let need = super::bounds::band_need(t, v, bvh.tolerance);
    let c = &q.centre;
    // A sampled sphere bounds its planes in closed form (`geometry::radial`) in the distance from
    // its centre: if that bound clears the threshold at the region's lowest distance, every
    // cluster is settled.
    if let Some(rad) = &bvh.radial {
        if rad.plane_bound(q.lower_distance_to(&rad.centre), m1) > need {
            return true;
        }
    }
    // So does a sampled capsule (`geometry::spine`), in the distance from its segment.
    if let Some(sp) = &bvh.spine {
        if sp.plane_bound(q.lower_distance_to(&sp.nearest(c)), m1) > need {
            return true;
        }
    }
    // So does a union of spheres and capsules (`geometry::rounded`), member by member, over a
    // region outside all of them.
    if let Some(un) = &bvh.rounded {
        if un.settles(c, |a| q.lower_distance_to(a), m1, need) {
            return true;
        }
    }
    // So does a sampled box, face by face (`geometry::cuboid`), over the box of the region's
    // coordinates along the box's axes.
    if let Some(cub) = &bvh.cuboid {
        let u = &cub.axes;
        let mid = u * c;
        let lo = Vector3::from_fn(|k, _| mid[k] + q.min_lin(&u.row(k).transpose()));
        let hi = Vector3::from_fn(|k, _| mid[k] - q.min_lin(&-u.row(k).transpose()));
        if cub.settles(&lo, &hi, c.norm() + q.radius, need, m1) {
            return true;
        }
    }
    false
}
