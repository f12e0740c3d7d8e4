//! The pair force's exact Jacobian with respect to the bodies' relative motion, derived by hand
//! in `f64` and chained with first-order dual numbers, so derivatives do not carry every
//! direction through every term.

use super::*;
use crate::collision::Linearized;

/// Number of inputs of [`pair_jacobian`] per side: the rotation (9 entries, row-major), the
/// translation, the linear velocity, the query body's and the plane body's angular velocities
/// of a [`Relative`].
pub const SIDE_INPUTS: usize = 21;
/// Number of outputs of [`pair_jacobian`]: per side the force and torque on the query body and
/// on the plane body (plane body's frame), then the distance.
pub const PAIR_OUTPUTS: usize = 25;

pub(super) fn relative_inputs<T: Scalar>(r: &Relative<T>) -> [T; SIDE_INPUTS] {
    let mut out = [T::zero(); SIDE_INPUTS];
    for j in 0..3 {
        for k in 0..3 {
            out[3 * j + k] = r.rotation[(j, k)];
        }
    }
    for (i, v) in [&r.translation, &r.linvel, &r.angvel, &r.angvel_planes]
        .into_iter()
        .enumerate()
    {
        out[9 + 3 * i..12 + 3 * i].copy_from_slice(v.as_slice());
    }
    out
}

pub(super) fn pair_contact_chained<T: Scalar>(
    a: &Collider,
    fa: &Frame<T>,
    b: &Collider,
    fb: &Frame<T>,
    prm: &ContactParams<T>,
    kept: Option<&mut Option<Box<Linearized>>>,
    scratch: &mut Scratch,
) -> PairContact<T> {
    let rels = [fa.relative_to(fb), fb.relative_to(fa)];
    let mut inputs = [T::zero(); 2 * SIDE_INPUTS];
    inputs[..SIDE_INPUTS].copy_from_slice(&relative_inputs(&rels[0]));
    inputs[SIDE_INPUTS..].copy_from_slice(&relative_inputs(&rels[1]));
    let (rels_re, prm_re) = ([rels[0].re(), rels[1].re()], prm.re());
    // The key, only where there is a memo: the real inputs and every parameter the Jacobian
    // reads (surfaces are at rest on this path).
    let key: Option<Vec<f64>> = kept.is_some().then(|| {
        (inputs.iter().map(|x| x.re()))
            .chain([
                prm_re.eps1,
                prm_re.eps1_scale[0],
                prm_re.eps1_scale[1],
                prm_re.eps2,
                prm_re.eps3,
                prm_re.stiffness,
                prm_re.dissipation_velocity,
                prm_re.stiction_velocity,
                prm_re.friction,
                prm_re.dissipation_force,
                f64::from(u8::from(prm_re.hold_separation)),
                prm_re.margin,
                prm_re.adhesion,
                prm_re.gap,
                prm_re.pull.unwrap_or(-1.0),
                prm_re.dissipation as u8 as f64,
            ])
            .collect()
    });
    let found = (kept.as_deref().and_then(Option::as_deref))
        .filter(|l| key.as_deref().is_some_and(|k| l.taken_at(k)));
    let mut out = [T::zero(); PAIR_OUTPUTS];
    let chained = match found {
        Some(l) => T::chain(&l.values, &l.jacobian, &inputs, &mut out),
        None => {
            let (values, jac) = pair_jacobian(a, b, &rels_re, &prm_re, scratch);
            let chained = T::chain(&values, &jac, &inputs, &mut out);
            if let (Some(slot), Some(key)) = (kept, key) {
                *slot = Some(Box::new(Linearized {
                    key,
                    values: values.to_vec(),
                    jacobian: jac,
                }));
            }
            chained
        }
    };
    if !chained {
        return pair_contact_generic(a, fa, b, fb, prm);
    }
    let sums = [
        SideSums::from_flat(&out[..12]),
        SideSums::from_flat(&out[12..24]),
    ];
    let [on_a, on_b] = SideSums::wrenches(sums, fa, fb);
    PairContact {
        on_a,
        on_b,
        distance: out[24],
    }
}

/// `[v]×`, the matrix of `w ↦ v × w`.
pub(super) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// `λ` of [`point_plane_force`] (`f64`) with its exact derivatives `∂λ/∂φ` (with `φ = nᵀr`)
/// and `∂λ/∂v` (3×3), hand-derived: `λ = c(φ) d(s) e` with `c = k s⁺_ε3(m - φ)`,
/// `s = nᵀv/V`, `V = v_d (1 + (c/F_d) g(nᵀv/v_d))`, `g(x) = 1 - tanh(x/2)`, `e = n - μ u`,
/// `u = v_t/N`, `N = sqrt(v_s² + |v_t|²)`. The spring moves `s` too
/// (`∂s/∂c = -s g/(F_d + c g)`), so `∂λ/∂φ = c'(φ) (d - c s d'(s) g/(F_d + c g)) e` with
/// `c' = -k / (1 + exp((φ - m)/ε3))` (the second term vanishes for an infinite `F_d`), and
/// `∂λ/∂v = c d'(s) (∂s/∂v_n) e nᵀ - (c μ d / N)(I - n nᵀ - u uᵀ)` with
/// `∂s/∂v_n = (1 - s (c/F_d) g'(x))/V` (`1/v_d` for an infinite `F_d`).
pub fn point_plane_force_jacobian(
    r: &Vector3<f64>,
    n: &Vector3<f64>,
    v: &Vector3<f64>,
    prm: &ContactParams<f64>,
) -> (Vector3<f64>, Vector3<f64>, Matrix3<f64>) {
    point_plane_force_jacobian_at(n.dot(r), n, v, prm)
}

/// [`point_plane_force_jacobian`] given the distance `phi` the spring reads
/// ([`point_plane_force_at`]).
pub fn point_plane_force_jacobian_at(
    phi: f64,
    n: &Vector3<f64>,
    v: &Vector3<f64>,
    prm: &ContactParams<f64>,
) -> (Vector3<f64>, Vector3<f64>, Matrix3<f64>) {
    let phi = phi - prm.margin;
    if phi > prm.bound_margin() - prm.margin + 746.0 * prm.eps3 {
        return (Vector3::zeros(), Vector3::zeros(), Matrix3::zeros());
    }
    // The spring c and its slope; with adhesion (departure 7) c = W f and the pull p = W δ,
    // W = σ((g - y)/ε3) with W' = -W (1 - W)/ε3, f = k s⁺_ε3(δ/k - y); the actuators' pull a
    // (departure 9) adds W a to the pull and leaves the plain spring where δ = 0. The same
    // operations in the same order as `spring_at`, so the values agree to the bit with
    // `point_plane_force_at`'s.
    let (window, dwindow) = if prm.adhesive() {
        let window = logistic((prm.gap - phi) / prm.eps3);
        (window, -window * (1.0 - window) / prm.eps3)
    } else {
        (1.0, 0.0)
    };
    let (spring, dspring) = if prm.adhesion > 0.0 {
        let shift = prm.adhesion / prm.stiffness;
        let f = softplus(shift - phi, prm.eps3);
        let df = -1.0 / (1.0 + ((phi - shift) / prm.eps3).exp());
        (
            window * prm.stiffness * f,
            prm.stiffness * (dwindow * f + window * df),
        )
    } else {
        let spring = prm.stiffness * softplus(-phi, prm.eps3);
        (spring, -prm.stiffness / (1.0 + (phi / prm.eps3).exp()))
    };
    // Zero where the pair cannot pull.
    let total = prm.pull.map_or(prm.adhesion, |a| a + prm.adhesion);
    let (pull, dpull) = (window * total, dwindow * total);
    let vn = n.dot(v);
    let vd = prm.dissipation_velocity_at(spring, vn);
    let (d, dd) = prm.dissipation.factor_slope(vn / vd);
    // s = v_n/V with V = v_d (1 + (c/F_d) g(v_n/v_d)): through the spring ∂s/∂c = -s g/(F_d + c g),
    // and along v_n ∂s/∂v_n = (1 - s (c/F_d) g'(x))/V, `along/V`; both the plain ones where F_d
    // (or v_d) is infinite (V = v_d, `along` 1: the same bits as before the share).
    // Without the share (`hold_separation` off) g = 1 and g' = 0.
    let (d_through_spring, along) = if prm.holds_separation() {
        // g and g' = -g (1 - g/2) from `separation_share`'s value, to the bit.
        let g = super::params::separation_share(vn / prm.dissipation_velocity);
        let dg = -g * (1.0 - 0.5 * g);
        let s = vn / vd;
        (
            d - spring * s * dd * g / (prm.dissipation_force + spring * g),
            1.0 - s * (spring / prm.dissipation_force) * dg,
        )
    } else if prm.dissipation_force.is_finite() {
        (
            d - spring * (vn / vd) * dd / (prm.dissipation_force + spring),
            1.0,
        )
    } else {
        (d, 1.0)
    };
    let pressed = spring * d;
    let vt = v - n * vn;
    let norm = smooth_norm(&vt, prm.stiction_velocity);
    let lambda_n = if prm.adhesive() {
        pressed - pull
    } else {
        pressed
    };
    let lambda = n * lambda_n + vt * (-prm.friction * pressed / norm);
    let u = vt / norm;
    let e = n - u * prm.friction;
    let dphi = e * (dspring * d_through_spring) - n * dpull;
    let dv = e * n.transpose() * (spring * dd * along / vd)
        - (Matrix3::identity() - n * n.transpose() - u * u.transpose())
            * (spring * prm.friction * d / norm);
    (lambda, dphi, dv)
}

/// Derivatives of one point–SSDF force with respect to its query point `x`, its velocity `v`
/// and the plane body's angular velocity `ω_p` (plane body's frame), from the terms' real
/// parts. With `σ_i = w_i/Z`, `∂w_i/∂x = -(2/ε1) w_i r_i`, and every plane reading the
/// sliding velocity `v_s = v - ω_p × x` (docs/method.md, departure 6):
/// `∂F/∂x = Σ σ_i λ_φ,i n_iᵀ - (2/ε1)(Σ σ_i λ_i r_iᵀ - F r̄ᵀ) - (∂F/∂v) [ω_p]×`
/// (`r̄ = Σ σ_i r_i`), `∂F/∂v = Σ σ_i ∂λ_i/∂v_s`, `∂F/∂ω_p = (∂F/∂v) [x]×`; the reaction's
/// moment `G = x × F` has `∂G/∂x = [x]× ∂F/∂x - [F]×` and `[x]×` on the left of the others.
/// A half-space (one plane, no softmax) has `σ = 1` and no weight derivative.
#[derive(Clone, Debug)]
pub(super) struct LocalJacobian {
    prm: ContactParams<f64>,
    /// The ε1 (m²) of the planes' softmax; `None` against a half-space (one plane).
    softmax: Option<f64>,
    z: f64,
    sr: Vector3<f64>,
    lphi_n: Matrix3<f64>,
    lam_r: Matrix3<f64>,
    lv: Matrix3<f64>,
}

impl ForceSink for LocalJacobian {
    const ON: bool = true;
    fn term(&mut self, t: &PlaneTerm) {
        let (w, r, n, v, phi, dphi) = (t.w, &t.r, t.n, &t.v, t.phi, t.dphi);
        let (lambda, lphi, lv) = point_plane_force_jacobian_at(phi, n, v, &self.prm);
        self.z += w;
        self.sr += r * w;
        self.lphi_n += lphi * dphi.transpose() * w;
        self.lam_r += lambda * r.transpose() * w;
        self.lv += lv * w;
    }
}

impl LocalJacobian {
    fn new(prm: &ContactParams<f64>) -> Self {
        let z = Matrix3::zeros();
        LocalJacobian {
            prm: *prm,
            softmax: None,
            z: 0.0,
            sr: Vector3::zeros(),
            lphi_n: z,
            lam_r: z,
            lv: z,
        }
    }

    /// `(∂F/∂x, ∂F/∂v, ∂F/∂ω_p, ∂G/∂x, ∂G/∂v, ∂G/∂ω_p)` given the force `F` at the query
    /// point `x` against planes turning with `ω_p`.
    fn blocks(
        &self,
        f: &Vector3<f64>,
        x: &Vector3<f64>,
        omega_p: &Vector3<f64>,
    ) -> [Matrix3<f64>; 6] {
        let inv = 1.0 / self.z;
        let fv = self.lv * inv;
        let mut fx = self.lphi_n * inv - fv * skew(omega_p);
        if let Some(eps1) = self.softmax {
            let k = 2.0 / eps1;
            let rbar = self.sr * inv;
            fx += (f * rbar.transpose() - self.lam_r * inv) * k;
        }
        let xx = skew(x);
        let fw = fv * xx;
        [fx, fv, fw, xx * fx - skew(f), xx * fv, xx * fw]
    }
}

/// The pair's outputs in the plane frames (per side `f_q, t_q, f_p, t_p`, see
/// [`PAIR_OUTPUTS`]), the distance last, and their exact Jacobian (row-major,
/// `PAIR_OUTPUTS × 2·SIDE_INPUTS`) with respect to the two [`Relative`] motions (inputs in the
/// order of [`SIDE_INPUTS`]): the value of [`pair_contact_generic`] at `f64`, and the derivative
/// that `Dual64` would carry through it, computed by hand.
///
/// Derivation. Entry `f` of side `s` has query point `a_f` (its body's frame), `arm_f = R a_f`,
/// `x_f = arm_f + t`, `v_f = u + ω_q × arm_f`; its SSDF `Φ_f` depends on `x_f` (gradient
/// [`GradientSink`](crate::geometry::ssdf::GradientSink)); its point force `F_f`, `G_f` on `x_f`, `v_f`, `ω_p` (`LocalJacobian`).
/// `W_f = exp(-Φ_f/ε2)/Σ_g exp(-Φ_g/ε2)`, so `dW_f = -(W_f/ε2)(dΦ_f - dΦ̄)` with
/// `dΦ̄ = Σ_g W_g dΦ_g` over every entry with a weight. For a side's output
/// `S = Σ_f W_f s_f`: `dS = Σ_f W_f (ds_f - s_f dΦ_f/ε2) + S dΦ̄/ε2`, and
/// `dD = Σ_g W_g (1 - (Φ_g - D)/ε2) dΦ_g`. Finally `dx_f = dR a_f + dt`,
/// `dv_f = du - [arm_f]× dω_q + [ω_q]× dR a_f`, `d arm_f = dR a_f`.
///
/// The paper's law only: a pair whose surfaces move (`prm.surface`, docs/method.md,
/// departure 8) is refused (a panic); [`pair_contact`](super::pair_contact) takes dual numbers
/// through such a pair instead.
pub fn pair_jacobian(
    a: &Collider,
    b: &Collider,
    rels: &[Relative<f64>; 2],
    prm: &ContactParams<f64>,
    scratch: &mut Scratch,
) -> ([f64; PAIR_OUTPUTS], Vec<f64>) {
    assert!(
        prm.surface.is_none() && rels.iter().all(|r| r.surface.is_none()),
        "pair_jacobian is derived for surfaces at rest"
    );
    const NI: usize = 2 * SIDE_INPUTS;
    let mut jac = vec![0.0; PAIR_OUTPUTS * NI];
    let mut grads = Vec::new();
    let mut records: Vec<(usize, f64, PointForce<f64>, LocalJacobian)> = Vec::new();
    // The planes of side 0 are b's, of side 1 a's: against a half-space there is no softmax.
    let halfspace = [
        matches!(b, Collider::HalfSpace { .. }),
        matches!(a, Collider::HalfSpace { .. }),
    ];
    let parts = pair_sides(
        a,
        b,
        rels,
        prm,
        BandWork {
            keep_terms: terms_budget(a, b),
            scratch,
            grads: Some(&mut grads),
            memo: None,
        },
        || LocalJacobian::new(prm),
        |i, w, pf, snk| records.push((i, w, *pf, snk)),
    );
    let mut values = [0.0; PAIR_OUTPUTS];
    values[..12].copy_from_slice(&parts.sums[0].flat());
    values[12..24].copy_from_slice(&parts.sums[1].flat());
    values[24] = parts.dist.distance;
    if !parts.dist.min.is_finite() {
        return (values, jac);
    }
    let (band, dist) = (&parts.band, &parts.dist);
    let e2 = prm.eps2;
    let eps1 = prm.eps1_sides();
    let query = |side: usize| -> &Aopc {
        match if side == 0 { a } else { b } {
            Collider::Aopc(s) => s,
            Collider::HalfSpace { .. } => unreachable!("a band entry is a point of an AOPC"),
        }
    };
    fn add(jac: &mut [f64], row: usize, col: usize, m: &Matrix3<f64>, sign: f64) {
        for i in 0..3 {
            for j in 0..3 {
                jac[(row + i) * NI + col + j] += sign * m[(i, j)];
            }
        }
    }
    // Point forces.
    for (i, w, pf, snk) in &records {
        let e = &band.entries[*i];
        let side = e.side as usize;
        let rel = &rels[side];
        let a_f = query(side).bvh().points[e.k as usize];
        let arm = rel.rotation * a_f;
        let g = grads[*i];
        let mut lj = snk.clone();
        lj.softmax = (!halfspace[side]).then_some(eps1[side]);
        let [fx, fv, fw, gx, gv, gw] =
            lj.blocks(&pf.force, &(arm + rel.translation), &rel.angvel_planes);
        let wf = pf.force * *w;
        let (ax, av, aw) = ((fx - pf.force * g.transpose() / e2) * *w, fv * *w, fw * *w);
        let (bx, bv, bw) = ((gx - pf.moment * g.transpose() / e2) * *w, gv * *w, gw * *w);
        let wq = skew(&rel.angvel);
        let armx = skew(&arm);
        let (ka, kb) = (ax + av * wq, bx + bv * wq);
        let (row, col) = (12 * side, SIDE_INPUTS * side);
        // d(W F) and d(W G) by input block: translation, velocity, ω_q, ω_p.
        let blocks_a = [(9, ax), (12, av), (15, -av * armx), (18, aw)];
        let blocks_b = [(9, bx), (12, bv), (15, -bv * armx), (18, bw)];
        for (off, m) in blocks_a {
            add(&mut jac, row, col + off, &m, 1.0);
            add(&mut jac, row + 6, col + off, &m, -1.0);
            add(&mut jac, row + 3, col + off, &(armx * m), 1.0);
        }
        for (off, m) in blocks_b {
            add(&mut jac, row + 9, col + off, &m, -1.0);
        }
        // The rotation block: ∂/∂R_jk = K[:, j] a_k (and -[W F]×[:, j] a_k for d arm × W F).
        let wfx = skew(&wf);
        for j in 0..3 {
            for k in 0..3 {
                let c0 = col + 3 * j + k;
                let (da, db) = (ka.column(j) * a_f[k], kb.column(j) * a_f[k]);
                let dt = armx * da - wfx.column(j) * a_f[k];
                for m in 0..3 {
                    jac[(row + m) * NI + c0] += da[m];
                    jac[(row + 6 + m) * NI + c0] -= da[m];
                    jac[(row + 3 + m) * NI + c0] += dt[m];
                    jac[(row + 9 + m) * NI + c0] -= db[m];
                }
            }
        }
    }
    // The separation distribution's normaliser (dΦ̄) and the distance.
    let d = dist.distance;
    let mut bar = [[0.0; 12]; 2];
    let mut dd = [[0.0; 12]; 2];
    for (e, g) in band.entries.iter().zip(&grads) {
        let phi = e.phi;
        if phi - dist.min > 746.0 * e2 {
            continue;
        }
        let w = (-(phi - dist.min) / e2).exp() / dist.normaliser;
        let a_f = query(e.side as usize).bvh().points[e.k as usize];
        let cd = w * (1.0 - (phi - d) / e2);
        let (b, dr) = (&mut bar[e.side as usize], &mut dd[e.side as usize]);
        for j in 0..3 {
            for k in 0..3 {
                b[3 * j + k] += w * g[j] * a_f[k];
                dr[3 * j + k] += cd * g[j] * a_f[k];
            }
            b[9 + j] += w * g[j];
            dr[9 + j] += cd * g[j];
        }
    }
    for (side, (b, dr)) in bar.iter().zip(&dd).enumerate() {
        let col = SIDE_INPUTS * side;
        for m in 0..12 {
            for (row, value) in values[..24].iter().enumerate() {
                jac[row * NI + col + m] += value / e2 * b[m];
            }
            jac[24 * NI + col + m] += dr[m];
        }
    }
    (values, jac)
}
