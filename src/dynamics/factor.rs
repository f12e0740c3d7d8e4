//! The joint-space inertia matrix factored along the tree: `M = Lᵀ D L`.
//!
//! Each velocity coordinate (DOF) has a parent DOF: the previous one of its joint, or the last
//! one of the nearest joint above it in the tree (none for a joint attached to the world
//! through jointless bodies only). `M(q)` has an entry between two DOFs only when one is an
//! ancestor of the other, and factoring from the leaves towards the root, as
//! `M = Lᵀ D L` with `L` unit lower triangular, fills in nothing else: every row of `L` has
//! entries only at the ancestors of its DOF (Featherstone, *Rigid Body Dynamics Algorithms*,
//! §6.5; MuJoCo factors its `M` the same way). So a row costs the depth of its DOF, not the
//! number of DOFs: `k` free bodies cost `k` factorizations of 6 × 6, a branching tree (a
//! humanoid's limbs) costs each limb its own chain, and nothing is allocated besides the
//! factor itself. Anything that keeps this sparsity may be added to `M` before factoring: a
//! diagonal (armature, damped Euler's `h D`).
//!
//! Written here rather than taken from nalgebra: its dense Cholesky neither sees the tree's
//! sparsity nor works in place, and on the free bodies of a scene with no contact the
//! allocations and the dense work were a fifth of a step (measured on `floating3`, three
//! free bodies out of reach).

use super::Tree;
use crate::scalar::Scalar;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// A factored joint-space inertia matrix ([`Tree::factor`]): `M = Lᵀ D L`.
pub struct MassFactor<T: Scalar> {
    /// `D` on the diagonal, `L`'s entries below it (row: a DOF, columns: its ancestors); the
    /// entries above the diagonal are the input's, unused.
    ld: DMatrix<T>,
    /// Parent DOF of each DOF.
    parent: Arc<[Option<usize>]>,
}

impl Tree {
    /// The parent DOF of each DOF (module documentation), in coordinate order: every parent
    /// comes before its child.
    pub(super) fn dof_parents(&self) -> Vec<Option<usize>> {
        let mut parent = vec![None; self.nv];
        // Per node: the last DOF at or above it.
        let mut last: Vec<Option<usize>> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let mut above = node.parent.and_then(|p| last[p]);
            if let Some(j) = node.joint {
                let joint = &self.joints[j];
                for (d, p) in parent
                    .iter_mut()
                    .enumerate()
                    .skip(joint.dadr)
                    .take(joint.kind.nv())
                {
                    *p = above;
                    above = Some(d);
                }
            }
            last.push(above);
        }
        parent
    }

    /// The factorization `M = Lᵀ D L` of `m`, the joint-space inertia matrix of this tree plus
    /// anything that keeps its sparsity (a diagonal), in place along the tree (module
    /// documentation). Only the entries on the diagonal and at each DOF's ancestors below it
    /// are read. `None` when a pivot of `D` is not positive or not finite (`m` is not positive
    /// definite, or a read entry is not finite).
    ///
    /// # Panics
    /// If `m` is not `nv × nv`.
    pub fn factor<T: Scalar>(&self, mut m: DMatrix<T>) -> Option<MassFactor<T>> {
        let (parent, n) = (&self.dof_parent, self.nv);
        assert_eq!(m.shape(), (n, n), "a mass matrix of {n} coordinates");
        // Column-major: entry (r, c) at r + c n.
        let e = m.as_mut_slice();
        for k in (0..n).rev() {
            let d = e[k + k * n];
            // A zero, negative, infinite or NaN pivot is refused.
            let positive = d.re() > 0.0 && d.re().is_finite();
            if !positive {
                return None;
            }
            let mut i = parent[k];
            while let Some(a) = i {
                let l = e[k + a * n] / d;
                // Removes row k's part from the rows above it: M[a][b] -= l · M[k][b] for the
                // ancestors b of a (and a itself).
                let mut j = Some(a);
                while let Some(b) = j {
                    let update = l * e[k + b * n];
                    e[a + b * n] -= update;
                    j = parent[b];
                }
                e[k + a * n] = l;
                i = parent[a];
            }
        }
        Some(MassFactor {
            ld: m,
            parent: self.dof_parent.clone(),
        })
    }
}

impl<T: Scalar> MassFactor<T> {
    /// `M⁻¹ rhs`: `x = L⁻¹ D⁻¹ L⁻ᵀ rhs`, each product along the tree.
    ///
    /// # Panics
    /// If `rhs` does not have one entry per coordinate.
    pub fn solve(&self, rhs: &DVector<T>) -> DVector<T> {
        let (parent, n) = (&self.parent, rhs.len());
        assert_eq!(
            n,
            parent.len(),
            "a right-hand side of {} coordinates",
            parent.len()
        );
        let ld = self.ld.as_slice();
        let mut out = rhs.clone();
        let x = out.as_mut_slice();
        // Lᵀ y = rhs, from the leaves.
        for k in (0..n).rev() {
            let mut i = parent[k];
            while let Some(a) = i {
                let update = ld[k + a * n] * x[k];
                x[a] -= update;
                i = parent[a];
            }
        }
        for k in 0..n {
            x[k] /= ld[k + k * n];
        }
        // L x = z, from the root.
        for k in 0..n {
            let mut i = parent[k];
            while let Some(a) = i {
                let update = ld[k + a * n] * x[a];
                x[k] -= update;
                i = parent[a];
            }
        }
        out
    }
}
