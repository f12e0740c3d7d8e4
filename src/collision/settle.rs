//! One query point of a reach proof (`super::reach`) settled or found within reach: the first
//! look at the point nearest the other body ([`seed_within`]), and a point's springs summed
//! with their softmax weights ([`springs_settle`]) where its planes alone leave it unsettled.

use super::*;

/// Whether the point `x` (the frame of `o`) is settled by its springs against `o`: over its
/// relevant planes `rel` (found at `x`, as the band finds them), with softmax weights `σ_i`
/// and readings `φ_i` raised to at least the polytope's floor `low` (each plane's to its own,
/// [`crate::geometry::polytope::Polytope::lift_of`]),
/// `Σ_i σ_i s⁺_ε3(m - φ_i) ≤ ε3 Σ_i σ_i e^{(m - φ_i)/ε3} ≤ ε3 e^{-(t - m)/ε3}`, so the point
/// pushes less than a point whose every plane reads `t` (the reach distance, [`super::reach_distance`],
/// where that spring is τ ε3 over the speed and friction factor). Checked as
/// `Σ_i w_i e^{-(φ_i - t)/ε3} ≤ (1 - 1e-9) Σ_i w_i`, `w_i = e^{-(d_i - d_min)/ε1}`.
/// Where a plane reads nearer than `t` but weighs too little to matter (a curved part seen past
/// its nearest point: a hand beside a thigh 7 mm apart, whose planes 0.4 rad around read 2 mm),
/// the plane test fails and this settles the point. `false` without a spring (ε3 not
/// positive) or planes.
pub(super) fn springs_settle(
    o: &Aopc,
    x: &Vector3<f64>,
    eps1: f64,
    spring: SpringShape,
    t: f64,
    low: f64,
    rel: &Relevant,
) -> bool {
    if spring.eps3.is_nan() || spring.eps3 <= 0.0 || rel.items.is_empty() {
        return false;
    }
    let bvh = o.bvh();
    let (inv1, inv3) = (1.0 / eps1, 1.0 / spring.eps3);
    let (mut weights, mut springs) = (0.0, 0.0);
    let lifts = bvh.polytope.as_ref().filter(|_| low > f64::NEG_INFINITY);
    for &(k, d) in &rel.items {
        let (p, n) = (&bvh.points[k as usize], &bvh.normals[k as usize]);
        let low = lifts.map_or(low, |l| low + l.lift_of(k as usize));
        let phi = n.dot(&(x - p)).max(low);
        let e = -(d - rel.dmin) * inv1;
        weights += e.exp();
        springs += (e - (phi - t) * inv3).exp();
    }
    springs <= (1.0 - 1e-9) * weights
}

/// [`springs_settle`] at the point `x`, its relevant planes found into `scratch`.
pub(super) fn point_springs_settle(
    o: &Aopc,
    x: &Vector3<f64>,
    eps1: f64,
    spring: SpringShape,
    t: f64,
    scratch: &mut Relevant,
) -> bool {
    if spring.eps3.is_nan() || spring.eps3 <= 0.0 {
        return false;
    }
    scratch.find(o, x, eps1, usize::MAX);
    let low = o
        .bvh()
        .polytope
        .as_ref()
        .map_or(f64::NEG_INFINITY, |p| p.floor(x).lower());
    springs_settle(o, x, eps1, spring, t, low, scratch)
}

/// Whether one query point, the nearest to the other body of the leaf reached by descending
/// nearer-first (where a pair in contact usually touches), has its SSDF below `t` by more
/// than the pruning's and rounding's share, and (with a spring to bound) its springs above
/// the threshold's ([`springs_settle`]): then no proof can succeed, and the walk would
/// only fail later, after proving the nodes it meets before its first leaf in contact (about
/// ten node tests for a resting box). Asked once the root is not settled, so far pairs never
/// pay for it. The answer depends on the poses alone, and the walk gives `false` in every case
/// this does, so it changes no result: a walk that succeeds proves, at every point, either the
/// pruned SSDF above `t` (planes the proof counts irrelevant are within its bound's share) or
/// the same spring sum below its limit. The allowance is a generous rounding margin of the
/// computed mean.
pub(super) fn seed_within(
    q: &ReachQuestion,
    bvh: &crate::geometry::bvh::Bvh,
    vmax: f64,
    scratch: &mut Relevant,
) -> bool {
    let ReachQuestion {
        planes,
        rot,
        tr,
        t,
        eps1,
        spring,
        ..
    } = *q;
    let target = super::band::toward(planes, bvh);
    let far = |c: &Vector3<f64>| (rot * c + tr - target).norm_squared();
    let node = &bvh.nodes[super::band::seed_leaf(bvh, rot, tr, &target) as usize];
    let points = &bvh.points[node.start as usize..(node.start + node.count) as usize];
    let Some(p) = points.iter().min_by(|a, b| far(a).total_cmp(&far(b))) else {
        return false;
    };
    let x = rot * p + tr;
    let (phi, scale, settles) = match planes {
        Collider::HalfSpace { point, normal } => (normal.dot(&(x - point)), x.norm(), false),
        Collider::Aopc(o) => {
            scratch.find(o, &x, eps1, usize::MAX);
            if scratch.items.is_empty() {
                return false;
            }
            let floor = o.bvh().polytope.as_ref().map(|p| p.floor(&x));
            let low = floor.as_ref().map_or(f64::NEG_INFINITY, |f| f.lower());
            let (phi, _, _) = ssdf_over(
                o,
                &x,
                eps1,
                SpringShape::NONE,
                f64::NEG_INFINITY,
                scratch,
                &mut NoSink,
                None,
            );
            // The distance the model reads: raised to the floor, as the walk's proofs use it.
            let phi = floor.map_or(phi, |mut f| f.raise(phi).0);
            let settles = springs_settle(o, &x, eps1, spring, t, low, scratch);
            (phi, vmax, settles)
        }
    };
    phi < t - 1e-9 * (1.0 + t.abs() + scale) && !settles
}
