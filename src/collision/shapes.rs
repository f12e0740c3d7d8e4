//! A side of a pair settled by the two clouds' shapes alone, before any node of either
//! hierarchy is walked: where the query cloud's points lie within known distances of a few
//! segments ([`crate::geometry::holders`]) and the plane cloud bounds its relevant planes in
//! closed form in the distance from its own segments (a sampled sphere, capsule or rounded
//! union: [`crate::geometry::radial`], [`crate::geometry::spine`], [`crate::geometry::rounded`]),
//! the distance between segments bounds from below the distance from every query point to the
//! plane cloud's segments, and with it every relevant plane.
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
