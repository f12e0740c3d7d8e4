//! The separation band: the entries of the separation field whose weight can matter, found by
//! walking both bodies' bounding-volume hierarchies with the proven bounds of `bounds.rs`.

use super::bounds::*;
use super::*;

/// One evaluated entry of the separation field: a query point and its SSDF w.r.t. the other
/// body.
#[derive(Clone, Copy, Debug)]
pub struct BandEntry<T> {
    /// 0: a point of `a` against the planes of `b`; 1: a point of `b` against those of `a`.
    pub side: u8,
    /// The point's position in its AOPC's BVH leaf order (`bvh().index[k]` is its face).
    pub k: u32,
    /// `Φ_f` (m).
    pub phi: T,
    /// Smallest squared distance from the point to the other body's points (m², real part;
    /// the SSDF's softmax shift). Infinite against a half-space.
    pub dmin: f64,
    /// An upper bound of `Σ_i σ_i s⁺_ε3(m - φ_i)` over the planes the SSDF summed (m, real part;
    /// [`SpringBound`](crate::geometry::ssdf::SpringBound)): times the stiffness, it bounds the
    /// springs of this point's force. Infinite when the band was built without ε3.
    pub springs: f64,
    /// The SSDF's terms at this point, `SeparationBand::terms[start..end]`, when the band kept
    /// them (within its term budget); `None` otherwise and against a half-space.
    pub terms: Option<(u32, u32)>,
}

/// Where a walk of a query hierarchy heads first, in the frame of `planes`: the other body's
/// centre, or far behind a half-space's plane (where the deepest points usually are).
pub(super) fn toward(planes: &Collider, bvh: &crate::geometry::bvh::Bvh) -> Vector3<f64> {
    match planes {
        Collider::Aopc(o) => o.bvh().nodes[0].centre,
        Collider::HalfSpace { point, normal } => point - normal * 1e3 * bvh.diameter.max(1.0),
    }
}

/// The leaf of `bvh` (its points mapped by `x = rot p + tr`) reached from the root by
/// descending nearer-first to `target`.
pub(super) fn seed_leaf(
    bvh: &crate::geometry::bvh::Bvh,
    rot: &Matrix3<f64>,
    tr: &Vector3<f64>,
    target: &Vector3<f64>,
) -> u32 {
    let far = |i: u32| (rot * bvh.nodes[i as usize].centre + tr - target).norm_squared();
    let mut ni = 0u32;
    while !bvh.nodes[ni as usize].is_leaf() {
        let l = bvh.nodes[ni as usize].left;
        ni = if far(l) <= far(l + 1) { l } else { l + 1 };
    }
    ni
}

/// Scratch space of [`band_of`]'s walk, part of a [`Scratch`]: a step walks several bands, and
/// growing these vectors again for each was about a twentieth of a resting stack's pairs.
#[derive(Default)]
pub(super) struct BandWalk {
    /// Open nodes of the other hierarchy, per entry of the stack (see the walk).
    arena: Vec<u32>,
    front: Vec<u32>,
    /// Node, witness hint, and the parent's open nodes `arena[from..to]`.
    stack: Vec<(u32, u32, u32, u32)>,
    /// The most entries and kept terms the last band walked here held before its cutoff
    /// dropped any: the next band's vectors start that large where no pair's own sizes are
    /// kept ([`CandidateMemo`]). The band is handed to its caller, so its vectors are new at
    /// each walk; grown from a fixed start they were reallocated a few times at every
    /// evaluation of a pair in contact.
    sizes: (usize, usize),
}

/// The part of the separation field that can carry weight (module documentation): every
/// entry whose weight is not provably below τ/(I1 + I2) relative to the largest.
#[derive(Clone, Debug)]
pub struct SeparationBand<T> {
    /// The entries within the cutoff, `Φ_f ≤ Φ_min + M2 ε2` (and any NaN one), in the walk's
    /// order: the same whichever proofs skipped the rest, or which candidates were kept.
    pub entries: Vec<BandEntry<T>>,
    /// `Φ_min`: the smallest entry (real part), the same as the full field's.
    pub min: f64,
    /// Number of query points not in the band (skipped by a proof, or beyond the cutoff).
    pub skipped: usize,
    /// Number of query points whose SSDF was evaluated (the band's and those that ended
    /// beyond the cutoff): what the proofs and kept bounds did not save.
    pub evaluated: usize,
    /// `M2 = ln((I1 + I2)/τ)`: entries with `(Φ_f - Φ_min)/ε2 > M2` weigh less than τ/(I1 + I2).
    pub margin: f64,
    /// The kept SSDF terms of the entries ([`BandEntry::terms`]): each plane's leaf-order index
    /// and softmax weight `w_i = exp(-(d_i - d_min)/ε1)`, in summation order. The point–SSDF
    /// force of an entry sums the same planes with the same weights, so it reads them here
    /// instead of walking the hierarchy and computing each weight again.
    pub terms: Vec<(u32, T)>,
}

/// Soft collision detection with pruning: the entries of the separation field that matter
/// (module documentation). `eps1` (m²): the ε1 each side reads the other body's planes with
/// (0: `a`'s points against `b`'s planes, 1: the reverse; [`crate::contact::eps1_sides`]),
/// `eps2` in m.
pub fn separation_band<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: [T; 2],
    eps2: T,
) -> SeparationBand<T> {
    let rels = [fa.relative_to(fb), fb.relative_to(fa)];
    let mut scratch = Scratch::default();
    band_of(
        a,
        b,
        &rels,
        eps1,
        eps2,
        SpringShape::NONE,
        BandWork::bare(&mut scratch),
    )
}

/// What a band walk works with beyond the pair and its smoothing: how many SSDF terms it keeps
/// for the forces, its scratch, where it pushes the gradients, and the pair's candidate memo.
pub(crate) struct BandWork<'w> {
    /// The SSDF terms kept at most (0: none; [`terms_budget`](super::terms_budget)).
    pub(crate) keep_terms: usize,
    /// Scratch space for the walk and its SSDF queries.
    pub(crate) scratch: &'w mut Scratch,
    /// Where `∇Φ_f` of each entry is pushed, if asked.
    pub(crate) grads: Option<&'w mut Vec<Vector3<f64>>>,
    /// The pair's candidate planes kept from one call to the next, if any.
    pub(crate) memo: Option<&'w mut CandidateMemo>,
}

impl BandWork<'_> {
    /// A walk that keeps no term and no memo and pushes no gradient, with `scratch`.
    pub(crate) fn bare(scratch: &mut Scratch) -> BandWork<'_> {
        BandWork {
            keep_terms: 0,
            scratch,
            grads: None,
            memo: None,
        }
    }
}

/// [`separation_band`] given the motion of each body in the other's frame (`rels[0]`: `a` seen
/// from `b`, `rels[1]`: `b` seen from `a`), with scratch space for the SSDF queries. With
/// `spring.eps3 > 0` (m), each entry bounds its springs ([`BandEntry::springs`]). From `work`
/// ([`BandWork`]): the SSDF terms of the entries that can end within the cutoff are kept
/// ([`SeparationBand::terms`]) while fewer than `keep_terms` are (0: none;
/// [`terms_budget`](super::terms_budget)): an entry past it has none, and its terms must be
/// summed again where they are needed. With `grads`, the gradient `∇Φ_f` of each entry with
/// respect to its query point (the other body's frame, real parts) is pushed, in the order of
/// the entries. With `memo`, each query point's candidate planes are kept from one call to the
/// next ([`CandidateMemo`]; the same band to the last bit, at less cost while the bodies move
/// little).
pub(crate) fn band_of<T: Scalar>(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<T>; 2],
    eps1: [T; 2],
    eps2: T,
    spring: SpringShape,
    work: BandWork<'_>,
) -> SeparationBand<T> {
    let BandWork {
        keep_terms,
        scratch,
        mut grads,
        memo: mut kept,
    } = work;
    let margin = ((a.len() + b.len()).max(1) as f64 / super::pair_tolerance(a, b)).ln();
    // Room for a resting contact's band at once, or for the pair's last band (with kept
    // candidates; else the last walked in this scratch) where it was larger (growing them a
    // few times cost more).
    let (last_entries, last_terms) = kept
        .as_deref()
        .map_or(scratch.band.sizes, |kc| kc.band_sizes);
    let mut band = SeparationBand {
        entries: Vec::with_capacity(last_entries.max(64)),
        min: f64::INFINITY,
        skipped: 0,
        evaluated: 0,
        margin,
        terms: Vec::with_capacity(last_terms.max(128)),
    };
    let e2 = re(eps2);
    let grads_from = grads.as_ref().map_or(0, |g| g.len());
    if let Some(kc) = kept.as_deref_mut() {
        kc.begin(eps1.map(re), a, b);
    }
    // Two passes. The seed pass evaluates one leaf per side, the one reached by descending
    // nearer-first to the other body's centre (where the deepest points usually are), so that
    // both sides' walks start from a small Φ_best: a walk of the first side no longer proves
    // its nodes against a Φ_best that only the second side would lower. The main pass walks
    // both hierarchies and leaves the seed leaves out (their entries are already in). Which
    // leaves are seeds depends on the poses only, as does the walk's order.
    // `seeds[side]`: the seed leaf's node index.
    let mut seeds = [u32::MAX; 2];
    // Taken from the scratch and put back at the end.
    let Scratch {
        band: walk,
        relevant: scratch,
        ..
    } = scratch;
    let BandWalk {
        mut arena,
        mut front,
        mut stack,
        ..
    } = std::mem::take(walk);
    for pass in 0..2 {
        for (side, query, planes, rel) in [(0u8, a, b, &rels[0]), (1u8, b, a, &rels[1])] {
            let Collider::Aopc(s) = query else { continue };
            if s.is_empty() || matches!(planes, Collider::Aopc(o) if o.is_empty()) {
                continue;
            }
            // The ε1 of the planes this side reads.
            let eps1 = eps1[side as usize];
            let e1 = re(eps1);
            let rot = rel.rotation.map(re);
            let tr = crate::scalar::re3(&rel.translation);
            let bvh = s.bvh();
            // Children are visited nearer-first to the other body's centre, so that a small Φ is
            // found early and prunes the rest.
            let target = toward(planes, bvh);
            // A bound on |x - p_i| for every query point of this side and every point of the
            // other body (the two root spheres), for `need` to be one threshold for the walk.
            let vmax = match planes {
                Collider::Aopc(o) => {
                    let (qr, or) = (&bvh.nodes[0], &o.bvh().nodes[0]);
                    ((rot * qr.centre + tr - or.centre).norm() + qr.radius + or.radius)
                        * (1.0 + 1e-12)
                }
                Collider::HalfSpace { .. } => f64::NAN,
            };
            // Each entry: node, the witness of its parent's bound (a start for the next search),
            // and the parent's open nodes of the other hierarchy (`arena[from..to]`; see
            // `aopc_exceeds`): a node walks only what its parent left open. The arena grows and
            // shrinks with the depth-first walk.
            arena.clear();
            arena.push(0);
            stack.clear();
            stack.push((0u32, u32::MAX, 0u32, 1u32));
            if pass == 0 {
                let ni = seed_leaf(bvh, &rot, &tr, &target);
                seeds[side as usize] = ni;
                stack[0].0 = ni;
            }
            let seed = seeds[side as usize];
            while let Some((ni, hint, from, to)) = stack.pop() {
                let node = &bvh.nodes[ni as usize];
                if pass == 1 && ni == seed {
                    continue; // done in the seed pass
                }
                arena.truncate(to as usize);
                let centre = rot * node.centre + tr;
                let mut witness = u32::MAX;
                let (mut cfrom, mut cto) = (from, to);
                // With kept candidates, a node whose proof failed at its last visits is not
                // tried again for a few ([`CandidateMemo::try_proof`]): its children start
                // from this node's hint and open nodes.
                let try_proof = band.min.is_finite()
                    && kept
                        .as_deref_mut()
                        .is_none_or(|kc| kc.try_proof(side as usize, ni));
                if !try_proof {
                    witness = hint;
                }
                if try_proof {
                    // The node's points lie in its ball cut by the slab along its normal cone's axis.
                    let region = QueryRegion {
                        centre,
                        radius: node.radius,
                        m: rot * node.axis,
                        lo: node.slab_lo,
                        hi: node.slab_hi,
                    };
                    let t = band.min + margin * e2;
                    // Every entry of the node is at least the polytope's floor over its ball
                    // (departure 3 of docs/method.md): far from the other body that proves
                    // what the far-field SSDF cannot.
                    if let Collider::Aopc(o) = planes {
                        if let Some(p) = &o.bvh().polytope {
                            if p.floor_over_ball(&centre, node.radius) > t {
                                continue;
                            }
                        }
                    }
                    let (exceeds, j) = match planes {
                        Collider::Aopc(o) => {
                            front.clear();
                            front.extend_from_slice(&arena[from as usize..to as usize]);
                            let r = aopc_exceeds(
                                o,
                                &region,
                                t,
                                (e1, 0.0),
                                hint as usize,
                                Some(vmax),
                                &front,
                                &mut arena,
                            );
                            (cfrom, cto) = (to, arena.len() as u32);
                            r
                        }
                        Collider::HalfSpace { .. } => {
                            ssdf_exceeds_over(planes, &region, t, e1, usize::MAX)
                        }
                    };
                    if exceeds {
                        continue;
                    }
                    if let Some(kc) = kept.as_deref_mut() {
                        kc.proof_failed(side as usize, ni);
                    }
                    witness = j as u32;
                }
                if node.is_leaf() {
                    // One walk of the other body's hierarchy for the whole leaf when the leaf is
                    // small against the reach of the softmax (√(ln(I/τ) ε1)): its ball's
                    // candidates are then about the points each query needs anyway. A leaf wider
                    // than that (sharp ε1) would gather far more candidates than any one point
                    // keeps, so each point walks on its own, from its neighbour's nearest point.
                    // Both give the same relevant set ([`Relevant`]). With kept candidates,
                    // each point reads its own.
                    let share = kept.is_none()
                        && match planes {
                            Collider::Aopc(o) => {
                                node.radius * node.radius <= o.bvh().log_terms * e1
                            }
                            Collider::HalfSpace { .. } => false,
                        };
                    if let (true, Collider::Aopc(o)) = (share, planes) {
                        scratch.find_ball(
                            o,
                            &centre,
                            node.radius * (1.0 + 1e-12) + 1e-12 * centre.norm(),
                            e1,
                        );
                    }
                    for k in node.start..node.start + node.count {
                        let x =
                            rel.rotation * lift3::<T>(&bvh.points[k as usize]) + rel.translation;
                        let entry = match planes {
                            Collider::Aopc(o) => {
                                let xr = crate::scalar::re3(&x);
                                // Proven above the running cutoff (so above the final one),
                                // by the kept candidates or by the polytope's floor under the
                                // SSDF and its planes (docs/method.md, departure 3), an entry
                                // would be dropped below: it is not evaluated.
                                let t = band.min + margin * e2;
                                if let Some(kc) = kept.as_deref_mut() {
                                    if kc.above(side as usize, k, &xr, t) {
                                        continue;
                                    }
                                }
                                let polytope = o.bvh().polytope.as_ref();
                                if polytope.is_some_and(|p| p.floor_by_axes(&xr) > t) {
                                    continue;
                                }
                                let mut floor = polytope.map(|p| p.floor(&x));
                                let low = floor.as_ref().map_or(f64::NEG_INFINITY, |f| f.lower());
                                if low > t {
                                    continue;
                                }
                                if let Some(kc) = kept.as_deref_mut() {
                                    kc.relevant(side as usize, k, s, o, &xr, e1, scratch);
                                } else if share {
                                    scratch.find_within(o, &xr, e1);
                                } else {
                                    let hint = scratch.nearest;
                                    scratch.find(o, &xr, e1, hint);
                                }
                                let start = band.terms.len();
                                let keeping = start < keep_terms;
                                let keep = keeping.then_some(&mut band.terms);
                                let (phi, springs) = match grads.as_deref_mut() {
                                    Some(g) => {
                                        let mut sink = GradientSink::default();
                                        let (phi, w, springs) = ssdf_over(
                                            o, &x, eps1, spring, low, scratch, &mut sink, keep,
                                        );
                                        let mut grad = sink.gradient(phi.re(), w.re(), e1);
                                        let phi = match floor.as_mut() {
                                            Some(f) => {
                                                let (raised, s) = f.raise(phi);
                                                if s > 0.0 {
                                                    grad = grad * (1.0 - s) + f.gradient() * s;
                                                }
                                                raised
                                            }
                                            None => phi,
                                        };
                                        g.push(grad);
                                        (phi, springs)
                                    }
                                    None => {
                                        let (phi, _, springs) = ssdf_over(
                                            o,
                                            &x,
                                            eps1,
                                            spring,
                                            low,
                                            scratch,
                                            &mut NoSink,
                                            keep,
                                        );
                                        (floor.as_mut().map_or(phi, |f| f.raise(phi).0), springs)
                                    }
                                };
                                // The minimum only falls, so an entry above the running
                                // cutoff now stays above the final one: its terms are dropped.
                                // ("Not above", as the force's test is, so that a NaN Φ or
                                // cutoff keeps them: NaN is never above.)
                                let above = phi.re() > band.min.min(phi.re()) + margin * e2;
                                let terms = (keeping && !above)
                                    .then_some((start as u32, band.terms.len() as u32));
                                if terms.is_none() {
                                    band.terms.truncate(start);
                                }
                                BandEntry {
                                    side,
                                    k,
                                    phi,
                                    dmin: scratch.dmin,
                                    springs,
                                    terms,
                                }
                            }
                            Collider::HalfSpace { normal, .. } => {
                                let phi = planes.signed_distance(&x, eps1);
                                // Above the running cutoff, so beyond the final one: dropped
                                // below whatever follows, so not made (its spring's bound is
                                // an `exp`). ("Above", so that a NaN stays.)
                                if phi.re() > band.min + margin * e2 {
                                    band.evaluated += 1;
                                    continue;
                                }
                                if let Some(g) = grads.as_deref_mut() {
                                    g.push(*normal);
                                }
                                let springs = if spring.eps3 > 0.0 {
                                    crate::scalar::softplus(spring.margin - phi.re(), spring.eps3)
                                        * (1.0 + 1e-12)
                                } else {
                                    f64::INFINITY
                                };
                                BandEntry {
                                    side,
                                    k,
                                    phi,
                                    dmin: f64::INFINITY,
                                    springs,
                                    terms: None,
                                }
                            }
                        };
                        band.min = band.min.min(entry.phi.re());
                        band.entries.push(entry);
                        band.evaluated += 1;
                    }
                } else {
                    let (l, r) = (node.left, node.left + 1);
                    let dl = (rot * bvh.nodes[l as usize].centre + tr - target).norm_squared();
                    let dr = (rot * bvh.nodes[r as usize].centre + tr - target).norm_squared();
                    if dl <= dr {
                        stack.extend([(r, witness, cfrom, cto), (l, witness, cfrom, cto)]);
                    } else {
                        stack.extend([(l, witness, cfrom, cto), (r, witness, cfrom, cto)]);
                    }
                }
            }
        }
    }
    // Only the entries within the final cutoff are the band: which others a walk evaluated
    // depends on how far its proofs got (and on what was kept), not on the poses alone. Kept
    // in walk order, whose order is the poses' alone, so the band is the same to the last bit
    // whichever sound proofs skipped what.
    // ("Beyond", so that a NaN entry stays: NaN is never beyond.)
    let sizes = (band.entries.len(), band.terms.len());
    if let Some(kc) = kept {
        kc.band_sizes = sizes;
    }
    let cutoff = band.min + margin * e2;
    let beyond = |e: &BandEntry<T>| e.phi.re() > cutoff;
    if let Some(g) = grads {
        let mut i = 0;
        g.retain(|_| {
            i += 1;
            i <= grads_from || !beyond(&band.entries[i - 1 - grads_from])
        });
    }
    // The kept terms follow, so that they too are the same whatever else was evaluated.
    let mut end = 0;
    band.entries.retain_mut(|e| {
        if beyond(e) {
            return false;
        }
        if let Some((from, to)) = e.terms {
            let len = to - from;
            band.terms
                .copy_within(from as usize..to as usize, end as usize);
            e.terms = Some((end, end + len));
            end += len;
        }
        true
    });
    band.terms.truncate(end as usize);
    let points = |c: &Collider| match c {
        Collider::Aopc(s) => s.len(),
        Collider::HalfSpace { .. } => 0,
    };
    band.skipped = points(a) + points(b) - band.entries.len();
    *walk = BandWalk {
        arena,
        front,
        stack,
        sizes,
    };
    band
}
