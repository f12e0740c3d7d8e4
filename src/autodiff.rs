//! The derivative engines: exact Jacobians and Hessians of any [`VectorFunction`] from its
//! generic code run on num-dual's dual numbers. [`crate::derivatives`] applies them to the
//! dynamics, a step and the separation distance.

use crate::model::DynamicsError;
use crate::scalar::{derivatives, seeded, Scalar};
use nalgebra::{Const, DMatrix, U1};
use num_dual::{Derivative, DualSVec64, HyperDualSVec64};

/// A vector function of a vector of reals, evaluable on every [`Scalar`]: the form the
/// derivative engines need (a closure cannot be generic over the scalar).
pub trait VectorFunction {
    /// Evaluates the function.
    fn eval<T: Scalar>(&self, x: &[T]) -> Result<Vec<T>, DynamicsError>;
}

/// Values and Jacobian `∂f/∂x` (rows: outputs, columns: inputs), exact, in passes of vector
/// dual numbers: one pass of width 16 up to 16 inputs, else `⌈n/8⌉` passes of width 8. One
/// pass matters for the contact: with first-order duals the pair's Jacobian is computed once
/// per pass in `f64` ([`pair_contact`](crate::contact::pair_contact)), whatever the width, so a
/// second pass would compute it again.
pub fn jacobian<F: VectorFunction + ?Sized>(
    f: &F,
    x: &[f64],
) -> Result<(Vec<f64>, DMatrix<f64>), DynamicsError> {
    match x.len() {
        0 => {
            let values = f.eval(x)?;
            let m = values.len();
            Ok((values, DMatrix::zeros(m, 0)))
        }
        1 => jacobian_width::<F, 1>(f, x),
        2 => jacobian_width::<F, 2>(f, x),
        3 | 4 => jacobian_width::<F, 4>(f, x),
        5..=8 => jacobian_width::<F, 8>(f, x),
        9..=16 => jacobian_width::<F, 16>(f, x),
        _ => jacobian_width::<F, 8>(f, x),
    }
}

/// How many passes of dual numbers [`jacobian`] takes for `n` inputs: one up to 16, else
/// `⌈n/8⌉`.
pub fn passes(n: usize) -> usize {
    if n <= 16 {
        1
    } else {
        n.div_ceil(8)
    }
}

fn jacobian_width<F: VectorFunction + ?Sized, const N: usize>(
    f: &F,
    x: &[f64],
) -> Result<(Vec<f64>, DMatrix<f64>), DynamicsError> {
    let n = x.len();
    let mut values = Vec::new();
    let mut jac = DMatrix::zeros(0, n);
    for start in (0..n).step_by(N) {
        let xd: Vec<DualSVec64<N>> = x
            .iter()
            .enumerate()
            .map(|(i, &xi)| seeded(xi, i.checked_sub(start)))
            .collect();
        let out = f.eval(&xd)?;
        if start == 0 {
            values = out.iter().map(|o| o.re).collect();
            jac = DMatrix::zeros(out.len(), n);
        }
        for (r, o) in out.iter().enumerate() {
            let e = derivatives(o);
            for k in 0..N.min(n - start) {
                jac[(r, start + k)] = e[k];
            }
        }
    }
    Ok((values, jac))
}

/// Block size of the Hessian passes.
const HB: usize = 4;

/// Values and the Hessian `∂²f_i/∂x∂x` of every output `i`, exact, in 4×4 blocks of
/// hyper-dual numbers.
pub fn hessians<F: VectorFunction + ?Sized>(
    f: &F,
    x: &[f64],
) -> Result<(Vec<f64>, Vec<DMatrix<f64>>), DynamicsError> {
    let n = x.len();
    let nb = n.div_ceil(HB);
    if nb == 0 {
        let values = f.eval(x)?;
        let m = values.len();
        return Ok((values, vec![DMatrix::zeros(0, 0); m]));
    }
    let mut values = Vec::new();
    let mut out: Vec<DMatrix<f64>> = Vec::new();
    for bi in 0..nb {
        for bj in bi..nb {
            let xd: Vec<HyperDualSVec64<HB, HB>> = x
                .iter()
                .enumerate()
                .map(|(i, &xi)| {
                    let mut d = HyperDualSVec64::<HB, HB>::from_re(xi);
                    if i / HB == bi {
                        d.eps1 = Derivative::derivative_generic(Const::<HB>, U1, i % HB);
                    }
                    if i / HB == bj {
                        d.eps2 = Derivative::derivative_generic(U1, Const::<HB>, i % HB);
                    }
                    d
                })
                .collect();
            let res = f.eval(&xd)?;
            if out.is_empty() {
                values = res.iter().map(|o| o.re).collect();
                out = vec![DMatrix::zeros(n, n); res.len()];
            }
            for (h, o) in out.iter_mut().zip(&res) {
                if let Some(e) = &o.eps1eps2.0 {
                    for a in 0..HB {
                        for b in 0..HB {
                            let (i, j) = (bi * HB + a, bj * HB + b);
                            if i < n && j < n {
                                h[(i, j)] = e[(a, b)];
                                h[(j, i)] = e[(a, b)];
                            }
                        }
                    }
                }
            }
        }
    }
    Ok((values, out))
}
