//! The joint-space inertia matrix with inertia added along constraint rows that cross the
//! tree's branches: `M + Jᵀ A J`, `A = diag(aᵢ) ≥ 0`, one row `Jᵢ` per constraint coordinate.
//!
//! MuJoCo's soft constraint with impedance `d` is, for its coordinate `r = J q`, a spring and
//! damper plus the inertia `aᵢ = d/(1 - d) Iᵢ` added along `Jᵢ` while it acts (docs/mjcf.md,
//! "Joint limits" and "Equality constraints"). A joint's limit adds it to one diagonal entry of
//! `M`, which keeps the tree's sparsity ([`crate::dynamics::Tree::factor`]); a tendon's limit or
//! an equality couples joints of several branches, and `Jᵀ A J` would fill the factor in. So
//! the tree's factor is kept and the rows are taken by Woodbury's identity:
//!
//! `(M + Jᵀ A J)⁻¹ b = x₀ - U (I + A J U)⁻¹ A J x₀`, `x₀ = M⁻¹ b`, `U = M⁻¹ Jᵀ`.
//!
//! This form (rather than the symmetric `(A⁻¹ + J U)⁻¹`) takes a row whose inertia is zero, or
//! falls smoothly to zero as its limit lets go, without dividing by it. `I + A J U` is
//! regular: `J U = J M⁻¹ Jᵀ` is positive semidefinite and `A ≥ 0`, so its eigenvalues are those
//! of `I + A^½ J U A^½`, at least one. The rows are few (a tendon limit that pushes, an
//! equality's one to six), so the `k` solves for `U` and the `k × k` LU cost little beside the
//! tree's factorization, and every later solve costs one tree solve and two products with `k`
//! rows.

use super::MassFactor;
use crate::scalar::Scalar;
use nalgebra::{DMatrix, DVector, Dyn, LU};

/// One constraint coordinate's row and the inertia it adds along it.
#[derive(Clone, Debug, PartialEq)]
pub struct Row<T: Scalar> {
    /// `Jᵢ`, one entry per velocity coordinate: `ṙ = Jᵢ v`.
    pub jacobian: DVector<T>,
    /// The added inertia `aᵢ ≥ 0` (kg or kg·m² per unit of `r`, as `Jᵢ` measures it).
    pub inertia: T,
}

/// `M + Jᵀ A J`, factored: the tree's factor of `M` and the rows' low-rank correction (see the
/// module).
pub struct CoupledFactor<T: Scalar> {
    tree: MassFactor<T>,
    rows: Option<LowRank<T>>,
}

/// What Woodbury's identity needs of the rows, computed once per factorization.
struct LowRank<T: Scalar> {
    /// `A J` (`k × n`).
    aj: DMatrix<T>,
    /// `U = M⁻¹ Jᵀ` (`n × k`).
    u: DMatrix<T>,
    /// `I + A J U`, factored.
    lu: LU<T, Dyn, Dyn>,
}

impl<T: Scalar> CoupledFactor<T> {
    /// `M + Σ aᵢ Jᵢᵀ Jᵢ` from the tree's factor of `M` and the rows (a row whose inertia is
    /// exactly zero, value and derivatives, is left out).
    pub fn new(tree: MassFactor<T>, rows: &[Row<T>]) -> CoupledFactor<T> {
        let zero = |x: T| x == T::zero();
        let rows: Vec<&Row<T>> = rows.iter().filter(|r| !zero(r.inertia)).collect();
        if rows.is_empty() {
            return CoupledFactor { tree, rows: None };
        }
        let (k, n) = (rows.len(), rows[0].jacobian.len());
        let aj = DMatrix::from_fn(k, n, |i, j| rows[i].jacobian[j] * rows[i].inertia);
        let mut u = DMatrix::zeros(n, k);
        for (i, r) in rows.iter().enumerate() {
            u.set_column(i, &tree.solve(&r.jacobian));
        }
        let small = DMatrix::from_fn(k, k, |i, j| {
            let dot = dot(aj.row(i).iter(), u.column(j).iter());
            if i == j {
                dot + T::one()
            } else {
                dot
            }
        });
        CoupledFactor {
            tree,
            rows: Some(LowRank {
                aj,
                u,
                lu: small.lu(),
            }),
        }
    }

    /// `(M + Jᵀ A J)⁻¹ rhs`.
    ///
    /// # Panics
    /// If `rhs` does not have one entry per coordinate.
    pub fn solve(&self, rhs: &DVector<T>) -> DVector<T> {
        let x = self.tree.solve(rhs);
        let Some(r) = &self.rows else {
            return x;
        };
        let ajx = DVector::from_fn(r.aj.nrows(), |i, _| dot(r.aj.row(i).iter(), x.iter()));
        let y =
            r.lu.solve(&ajx)
                .expect("I + A J M⁻¹ Jᵀ is regular (module documentation)");
        DVector::from_fn(x.len(), |i, _| x[i] - dot(r.u.row(i).iter(), y.iter()))
    }
}

/// `Σ aᵢ bᵢ` in order. The products are written out rather than left to nalgebra's, whose
/// `f64` products go through a blocked kernel that sums in another order than its generic one:
/// the values on dual numbers would then differ from those in `f64` by rounding, which the
/// Woodbury correction's cancellation magnifies (3e-12 of the accelerations, measured).
fn dot<'a, T: Scalar>(a: impl Iterator<Item = &'a T>, b: impl Iterator<Item = &'a T>) -> T {
    a.zip(b).fold(T::zero(), |s, (&x, &y)| s + x * y)
}
