//! Soft top-K contact points: the separation distribution moved onto the quad vertices and
//! its K largest picked by successive softmaxes.

use super::*;

/// Temperature of the soft top-K over vertex weights: `Γ_1 = softmax(ln z / t)`, so a vertex
/// carrying twice the weight of another is preferred by a factor `2^(1/t) = 1024`.
pub const TOPK_TEMPERATURE: f64 = 0.1;

/// Soft top-K contact points (paper eq. 16; docs/method.md): the separation distribution `W` moved
/// from faces to their vertices, `z_v = Σ_f [v ∈ f] W_f`, then `c_k = Σ_v Γ_kv y_v` with the
/// successive softmax `Γ_k = softmax(ℓ_k)`, `ℓ_1 = ln z / t` ([`TOPK_TEMPERATURE`]),
/// `ℓ_{k+1} = ℓ_k + ln(1 - Γ_k)`: closed form and smooth, no iterative solver. Points are in
/// the world frame (m); `eps1` (m²) is the ε1 each side reads the other body's planes with
/// ([`crate::contact::eps1_sides`]). Vertices of faces whose weight is below the pruning bound carry
/// nothing (their `z` would be below τ). If fewer than `k` vertices carry weight, the last
/// point repeats. Empty when neither body has points.
pub fn contact_points<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    eps1: [T; 2],
    eps2: T,
    k: usize,
) -> Vec<Vector3<T>> {
    let band = separation_band(a, fa, b, fb, eps1, eps2);
    let dist = SeparationDistribution::from_band(&band, eps2);
    if !dist.min.is_finite() || k == 0 {
        return Vec::new();
    }
    // Vertex weights z and vertex positions relative to a's origin (world axes), so that
    // bodies far from the world origin lose no precision.
    let cutoff = dist.min + band.margin * re(eps2);
    let mut z: std::collections::HashMap<(u8, u32), T> = std::collections::HashMap::new();
    for e in band.entries.iter().filter(|e| e.phi.re() <= cutoff) {
        let Collider::Aopc(s) = (if e.side == 0 { a } else { b }) else {
            continue;
        };
        let face = s.faces[s.bvh().index[e.k as usize] as usize];
        let w = dist.weight(0, e.phi);
        for (j, &v) in face.iter().enumerate() {
            if face[..j].contains(&v) {
                continue; // a triangle's face repeats its last corner
            }
            *z.entry((e.side, v)).or_insert(T::zero()) += w;
        }
    }
    let mut verts: Vec<((u8, u32), T)> = z.into_iter().collect();
    verts.sort_by_key(|(key, _)| *key); // a fixed order: sums do not depend on hashing
    let ys: Vec<Vector3<T>> = verts
        .iter()
        .map(|((side, v), _)| {
            let (s, f) = match (side, a, b) {
                (0, Collider::Aopc(s), _) => (s, fa),
                (_, _, Collider::Aopc(s)) => (s, fb),
                _ => unreachable!("weights come from AOPC faces"),
            };
            f.rotation * lift3::<T>(&s.vertices[*v as usize]) + (f.origin - fa.origin)
        })
        .collect();
    let inv_t = T::from(1.0 / TOPK_TEMPERATURE);
    let mut ell: Vec<T> = verts.iter().map(|(_, z)| z.ln() * inv_t).collect();
    let mut out: Vec<Vector3<T>> = Vec::with_capacity(k);
    for _ in 0..k {
        let (imax, lmax) = ell
            .iter()
            .enumerate()
            .filter(|(_, l)| l.re().is_finite())
            .fold((usize::MAX, f64::NEG_INFINITY), |m, (i, l)| {
                if l.re() > m.1 {
                    (i, l.re())
                } else {
                    m
                }
            });
        if imax == usize::MAX {
            let last = out.last().copied().unwrap_or_else(Vector3::zeros);
            out.push(last);
            continue;
        }
        let e: Vec<T> = ell
            .iter()
            .map(|l| {
                if l.re().is_finite() {
                    (*l - lmax).exp()
                } else {
                    T::zero()
                }
            })
            .collect();
        let total = e.iter().fold(T::zero(), |acc, x| acc + *x);
        let others = e
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != imax)
            .fold(T::zero(), |acc, (_, x)| acc + *x);
        let mut c = Vector3::zeros();
        for (ev, y) in e.iter().zip(&ys) {
            c += y * (*ev / total);
        }
        out.push(c);
        // ℓ_{k+1} = ℓ_k + ln(1 - Γ_k); for the largest entry 1 - Γ = (Σ others)/Σ, computed
        // without cancellation.
        for (i, l) in ell.iter_mut().enumerate() {
            if !l.re().is_finite() {
                continue;
            }
            let one_minus = if i == imax {
                others / total
            } else {
                T::one() - e[i] / total
            };
            *l = if one_minus.re() > 0.0 {
                *l + one_minus.ln()
            } else {
                T::from(f64::NEG_INFINITY)
            };
        }
    }
    out.into_iter().map(|c| c + fa.origin).collect()
}
