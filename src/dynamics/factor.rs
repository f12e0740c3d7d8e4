//! The joint-space inertia matrix factored subtree by subtree.
//!
//! Bodies in different subtrees of the world never share a chain of joints, so `M(q)` (and `M`
//! plus a diagonal, as damped Euler solves with) has no entry between their coordinates: up to
//! a permutation it is block diagonal, one block per subtree. Each block is factored on its
//! own, which for `k` free bodies is `k` Cholesky factorizations of 6 × 6 instead of one of
//! `6k × 6k` (about `k²` times fewer operations). The result equals the dense factorization's:
//! that one fills no entry outside the blocks, and inside them it adds only exact zeros to the
//! same sums.

use super::Tree;
use crate::scalar::Scalar;
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// A factored joint-space inertia matrix ([`Tree::factor`]).
pub struct MassFactor<T: Scalar> {
    parts: Parts<T>,
}

enum Parts<T: Scalar> {
    /// One subtree (or none): the whole matrix.
    Whole(Cholesky<T, Dyn>),
    /// Per subtree: its coordinates and the factor of its block.
    Blocks(Vec<(Vec<usize>, Cholesky<T, Dyn>)>),
}

impl Tree {
    /// The velocity coordinates of each subtree of the world (those of a subtree can couple
    /// in `M(q)`, those of different subtrees cannot), in coordinate order.
    pub(super) fn subtree_dofs(&self) -> Vec<Vec<usize>> {
        let mut root_of = vec![usize::MAX; self.nodes.len()];
        let mut blocks: Vec<(usize, Vec<usize>)> = Vec::new();
        for (i, node) in self.nodes.iter().enumerate() {
            root_of[i] = node.parent.map_or(i, |p| root_of[p]);
            let Some(j) = node.joint else { continue };
            let joint = &self.joints[j];
            let dofs = joint.dadr..joint.dadr + joint.kind.nv();
            match blocks.iter_mut().find(|(r, _)| *r == root_of[i]) {
                Some((_, d)) => d.extend(dofs),
                None => blocks.push((root_of[i], dofs.collect())),
            }
        }
        let mut blocks: Vec<Vec<usize>> = blocks.into_iter().map(|(_, d)| d).collect();
        blocks.iter_mut().for_each(|d| d.sort_unstable());
        blocks
    }

    /// The Cholesky factorization of `m`, the joint-space inertia matrix of this tree plus
    /// anything that keeps its sparsity (a diagonal), block by block (module documentation).
    /// `None` when a block is not positive definite.
    pub fn factor<T: Scalar>(&self, m: DMatrix<T>) -> Option<MassFactor<T>> {
        let parts = if self.blocks.len() <= 1 {
            Parts::Whole(m.cholesky()?)
        } else {
            let mut parts = Vec::with_capacity(self.blocks.len());
            for dofs in &self.blocks {
                let block = DMatrix::from_fn(dofs.len(), dofs.len(), |a, b| m[(dofs[a], dofs[b])]);
                parts.push((dofs.clone(), block.cholesky()?));
            }
            Parts::Blocks(parts)
        };
        Some(MassFactor { parts })
    }
}

impl<T: Scalar> MassFactor<T> {
    /// `M⁻¹ rhs`.
    pub fn solve(&self, rhs: &DVector<T>) -> DVector<T> {
        match &self.parts {
            Parts::Whole(ch) => ch.solve(rhs),
            Parts::Blocks(parts) => {
                let mut x = DVector::zeros(rhs.len());
                for (dofs, ch) in parts {
                    let b = DVector::from_fn(dofs.len(), |a, _| rhs[dofs[a]]);
                    let y = ch.solve(&b);
                    for (a, &d) in dofs.iter().enumerate() {
                        x[d] = y[a];
                    }
                }
                x
            }
        }
    }
}
