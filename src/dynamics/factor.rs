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

/// A matrix with the joint-space inertia matrix's sparsity ([`Tree::mass_matrix_sparse`]):
/// symmetric, its entries between a DOF and its ancestors only (module documentation), stored
/// row by row, each DOF's row its diagonal then its ancestors from the nearest up. `k` free
/// bodies hold `21 k` numbers where the dense matrix holds `36 k²`: MuJoCo's 300 leaves (1,800
/// velocities) built a dense matrix of 3.2 million dual numbers at every pass of an implicit
/// step's Jacobian, half of the step's time.
#[derive(Clone, Debug, PartialEq)]
pub struct TreeMatrix<T: Scalar> {
    vals: Vec<T>,
    shape: Arc<Sparsity>,
}

/// Where a [`TreeMatrix`]'s entries are, shared by every matrix of one tree.
#[derive(Debug, PartialEq)]
pub(super) struct Sparsity {
    /// Start of each DOF's row in a matrix's values, and the end of the last: row `k` holds
    /// `adr[k + 1] - adr[k]` entries, the DOF's depth plus one.
    adr: Vec<usize>,
    /// Per stored entry, its column: a row's DOF, then its ancestors from the nearest up. The
    /// factorization and the solves walk a row's ancestors as this slice, beside the row's
    /// values, rather than by following parents, and the mass matrix is written row by row
    /// (gymnasium's humanoid's first 0.3 s: 2.6 % fewer instructions; docs/performance.md).
    cols: Vec<usize>,
    /// Each DOF's depth: its number of ancestors.
    depth: Vec<usize>,
    /// Per DOF, whether it is the last of six DOFs in a chain from the root (a free joint's,
    /// or six joints of one DOF in a row at the top of a tree): their rows are 21 entries in
    /// a row, factored by [`factor_root_chain`].
    chain_end: Vec<bool>,
}

/// The DOFs of a root chain factored by the fixed loops of [`factor_root_chain`].
const CHAIN: usize = 6;

/// Entries of a root chain's rows ([`CHAIN`] rows of 1 to [`CHAIN`] entries).
const CHAIN_ENTRIES: usize = CHAIN * (CHAIN + 1) / 2;

impl Sparsity {
    /// The sparsity of the DOFs whose parents are `parent` (every parent before its child).
    pub(super) fn new(parent: &[Option<usize>]) -> Self {
        let n = parent.len();
        let mut depth = vec![0; n];
        let mut adr = Vec::with_capacity(n + 1);
        let mut cols = Vec::new();
        adr.push(0);
        for k in 0..n {
            depth[k] = parent[k].map_or(0, |p| depth[p] + 1);
            let mut i = Some(k);
            while let Some(a) = i {
                cols.push(a);
                i = parent[a];
            }
            adr.push(cols.len());
        }
        let chain_end = (0..n)
            .map(|k| {
                k + 1 >= CHAIN && {
                    let s = k + 1 - CHAIN;
                    parent[s].is_none() && (s + 1..=k).all(|d| parent[d] == Some(d - 1))
                }
            })
            .collect();
        Sparsity {
            adr,
            cols,
            depth,
            chain_end,
        }
    }

    /// Number of coordinates.
    fn dim(&self) -> usize {
        self.depth.len()
    }

    /// The stored range of row `k` in a matrix's values.
    #[inline]
    fn row(&self, k: usize) -> std::ops::Range<usize> {
        self.adr[k]..self.adr[k + 1]
    }
}

impl<T: Scalar> TreeMatrix<T> {
    /// The position of entry `(k, a)` in `vals`, `a` equal to `k` or one of its ancestors.
    #[inline]
    fn at(&self, k: usize, a: usize) -> usize {
        let sh = &*self.shape;
        sh.adr[k] + sh.depth[k] - sh.depth[a]
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.shape.dim()
    }

    /// Entry `(k, a)` for `a` equal to `k` or one of its ancestors (the lower triangle's
    /// stored entries; the matrix is symmetric).
    pub fn entry(&self, k: usize, a: usize) -> T {
        self.vals[self.at(k, a)]
    }

    /// Row `k` as stored: `(k, k)`, then `(k, a)` for its ancestors `a` from the nearest up.
    pub(super) fn row_mut(&mut self, k: usize) -> &mut [T] {
        let r = self.shape.row(k);
        &mut self.vals[r]
    }

    /// Rows `dofs` as stored, one after the other.
    pub(super) fn rows_mut(&mut self, dofs: std::ops::Range<usize>) -> &mut [T] {
        let sh = &*self.shape;
        let r = sh.adr[dofs.start]..sh.adr[dofs.end];
        &mut self.vals[r]
    }

    /// Entry `(k, a)`, written, for `a` equal to `k` or one of its ancestors.
    pub fn entry_mut(&mut self, k: usize, a: usize) -> &mut T {
        let i = self.at(k, a);
        &mut self.vals[i]
    }

    /// The dense symmetric matrix.
    pub fn to_dense(&self) -> DMatrix<T> {
        let n = self.dim();
        let mut m = DMatrix::zeros(n, n);
        for k in 0..n {
            let r = self.shape.row(k);
            for (&a, &x) in self.shape.cols[r.clone()].iter().zip(&self.vals[r]) {
                m[(k, a)] = x;
                m[(a, k)] = x;
            }
        }
        m
    }
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

    /// A zero matrix of this tree's sparsity ([`TreeMatrix`]).
    pub fn tree_matrix<T: Scalar>(&self) -> TreeMatrix<T> {
        TreeMatrix {
            vals: vec![T::zero(); self.dof_shape.cols.len()],
            shape: self.dof_shape.clone(),
        }
    }

    /// The entries of the dense `m` (`nv × nv`) at this tree's sparsity, read below the
    /// diagonal: `m` is taken as symmetric, the rest of it unread.
    ///
    /// # Panics
    /// If `m` is not `nv × nv`.
    pub fn sparse<T: Scalar>(&self, m: &DMatrix<T>) -> TreeMatrix<T> {
        let n = self.nv;
        assert_eq!(m.shape(), (n, n), "a matrix of {n} coordinates");
        let mut out = self.tree_matrix();
        let shape = out.shape.clone();
        for k in 0..n {
            let r = shape.row(k);
            for (&a, v) in shape.cols[r.clone()].iter().zip(&mut out.vals[r]) {
                *v = m[(k, a)];
            }
        }
        out
    }

    /// The factorization `M = Lᵀ D L` of `m`, the joint-space inertia matrix of this tree plus
    /// anything that keeps its sparsity (a diagonal), in place along the tree (module
    /// documentation). `None` when a pivot of `D` is not positive or not finite (`m` is not
    /// positive definite, or an entry is not finite).
    pub fn factor<T: Scalar>(&self, mut m: TreeMatrix<T>) -> Option<MassFactor<T>> {
        let n = m.dim();
        let shape = m.shape.clone();
        let adr = &shape.adr;
        let mut next = n;
        while next > 0 {
            let k = next - 1;
            if shape.chain_end[k] {
                // Every update the chain's rows receive from their descendants is done: those
                // rows come later in coordinate order, and were factored before.
                let s = k + 1 - CHAIN;
                let rows = &mut m.vals[adr[s]..adr[s] + CHAIN_ENTRIES];
                if !factor_root_chain(rows.try_into().expect("a root chain's 21 entries")) {
                    return None;
                }
                next = s;
                continue;
            }
            next = k;
            let rk = adr[k];
            // Every ancestor's row is stored before row k: split there, so that the updates
            // below read row k and write an ancestor's row as two slices, without bounds
            // checks in the innermost loop.
            let (above, row) = m.vals.split_at_mut(rk);
            let row = &mut row[..adr[k + 1] - rk];
            let d = row[0];
            // A zero, negative, infinite or NaN pivot is refused.
            let positive = d.re() > 0.0 && d.re().is_finite();
            if !positive {
                return None;
            }
            // Row k's entries past its diagonal are its ancestors in order, and each
            // ancestor's own row continues that list: M[a][b] -= l · M[k][b] for a and the
            // ancestors b of a is one contiguous update of row a.
            for (off, &a) in (1..).zip(&shape.cols[rk + 1..adr[k + 1]]) {
                let l = row[off] / d;
                let target = &mut above[adr[a]..adr[a + 1]];
                for (t, &x) in target.iter_mut().zip(&row[off..]) {
                    *t -= l * x;
                }
                row[off] = l;
            }
        }
        Some(MassFactor { ld: m })
    }
}

/// [`Tree::factor`]'s steps on the rows of a root chain of [`CHAIN`] DOFs (rows `0..CHAIN`,
/// row `k` its diagonal then its `k` ancestors from the nearest up, one after the other), in
/// the same order, so the same numbers: with the rows' lengths fixed, the loops unroll, where
/// the general loop's bookkeeping over rows of 1 to 6 entries cost about 20 instructions a
/// multiply–subtract (`floating3`, three free bodies). `false` when a pivot is not positive
/// or not finite.
fn factor_root_chain<T: Scalar>(rows: &mut [T; CHAIN_ENTRIES]) -> bool {
    for k in (0..CHAIN).rev() {
        let rk = chain_row(k);
        let d = rows[rk];
        if !(d.re() > 0.0 && d.re().is_finite()) {
            return false;
        }
        for off in 1..k + 1 {
            let l = rows[rk + off] / d;
            let ra = chain_row(k - off);
            for e in 0..k - off + 1 {
                let x = rows[rk + off + e];
                rows[ra + e] -= l * x;
            }
            rows[rk + off] = l;
        }
    }
    true
}

/// Where row `k` of a root chain starts among its entries.
#[inline]
const fn chain_row(k: usize) -> usize {
    k * (k + 1) / 2
}

/// A factored joint-space inertia matrix ([`Tree::factor`]): `M = Lᵀ D L`, `D` on the
/// diagonal of a [`TreeMatrix`] and `L`'s entries below it (row: a DOF, columns: its
/// ancestors).
pub struct MassFactor<T: Scalar> {
    ld: TreeMatrix<T>,
}

impl<T: Scalar> MassFactor<T> {
    /// `M⁻¹ rhs`: `x = L⁻¹ D⁻¹ L⁻ᵀ rhs`, each product along the tree.
    ///
    /// # Panics
    /// If `rhs` does not have one entry per coordinate.
    pub fn solve(&self, rhs: &DVector<T>) -> DVector<T> {
        let ld = &self.ld;
        let n = ld.dim();
        assert_eq!(rhs.len(), n, "a right-hand side of {n} coordinates");
        let mut out = rhs.clone();
        let x = out.as_mut_slice();
        let sh = &*ld.shape;
        // Row k's entries past its diagonal, with their columns (its ancestors).
        let below = |k: usize| {
            let r = sh.adr[k] + 1..sh.adr[k + 1];
            sh.cols[r.clone()].iter().zip(&ld.vals[r])
        };
        // A root chain's rows ([`factor_root_chain`]) and its coordinates, for loops of fixed
        // length: the same operations in the same order.
        let chain = |s: usize| -> (&[T; CHAIN_ENTRIES], std::ops::Range<usize>) {
            let rows = &ld.vals[sh.adr[s]..sh.adr[s] + CHAIN_ENTRIES];
            (
                rows.try_into().expect("a root chain's 21 entries"),
                s..s + CHAIN,
            )
        };
        // Lᵀ y = rhs, from the leaves.
        let mut next = n;
        while next > 0 {
            let k = next - 1;
            if sh.chain_end[k] {
                let (rows, dofs) = chain(k + 1 - CHAIN);
                let xs: &mut [T; CHAIN] = (&mut x[dofs.clone()]).try_into().expect("six");
                for k in (0..CHAIN).rev() {
                    let xk = xs[k];
                    for off in 1..k + 1 {
                        xs[k - off] -= rows[chain_row(k) + off] * xk;
                    }
                }
                next = dofs.start;
                continue;
            }
            next = k;
            let xk = x[k];
            for (&a, &l) in below(k) {
                x[a] -= l * xk;
            }
        }
        for (k, xk) in x.iter_mut().enumerate() {
            *xk /= ld.vals[sh.adr[k]];
        }
        // L x = z, from the root.
        let mut k = 0;
        while k < n {
            if k + CHAIN <= n && sh.chain_end[k + CHAIN - 1] {
                let (rows, dofs) = chain(k);
                let xs: &mut [T; CHAIN] = (&mut x[dofs.clone()]).try_into().expect("six");
                for k in 0..CHAIN {
                    let mut xk = xs[k];
                    for off in 1..k + 1 {
                        xk -= rows[chain_row(k) + off] * xs[k - off];
                    }
                    xs[k] = xk;
                }
                k = dofs.end;
                continue;
            }
            let mut xk = x[k];
            for (&a, &l) in below(k) {
                xk -= l * x[a];
            }
            x[k] = xk;
            k += 1;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two root chains of six DOFs (the first with a branch of two below its end and one
    /// more beside it), a chain of seven (one window of six only at its top), and a DOF
    /// alone: every path of the factor and the solves.
    const PARENTS: [Option<usize>; 23] = [
        None,
        Some(0),
        Some(1),
        Some(2),
        Some(3),
        Some(4),
        Some(5),
        Some(6),
        Some(5),
        None,
        Some(9),
        Some(10),
        Some(11),
        Some(12),
        Some(13),
        None,
        Some(15),
        Some(16),
        Some(17),
        Some(18),
        Some(19),
        Some(20),
        None,
    ];

    /// A diagonally dominant matrix at the sparsity `shape`: positive definite.
    fn matrix(shape: &Arc<Sparsity>, state: &mut u64) -> TreeMatrix<f64> {
        let mut vals = vec![0.0; shape.cols.len()];
        for k in 0..shape.dim() {
            for (e, v) in vals[shape.row(k)].iter_mut().enumerate() {
                let x = crate::geometry::lcg(state);
                *v = if e == 0 { 10.0 + x } else { x };
            }
        }
        TreeMatrix {
            vals,
            shape: shape.clone(),
        }
    }

    #[test]
    fn root_chains_factor_and_solve_as_the_general_loop_bit_for_bit() {
        let chains = Arc::new(Sparsity::new(&PARENTS));
        let mut general = Sparsity::new(&PARENTS);
        let ends: Vec<usize> = (0..PARENTS.len())
            .filter(|&k| chains.chain_end[k])
            .collect();
        assert_eq!(ends, [5, 14, 20]);
        general.chain_end.fill(false);
        let general = Arc::new(general);
        let tree = Tree::new(vec![], vec![], nalgebra::Vector3::zeros()).unwrap();
        let mut state = 3;
        for _ in 0..20 {
            let m = matrix(&chains, &mut state);
            let g = TreeMatrix {
                vals: m.vals.clone(),
                shape: general.clone(),
            };
            let rhs = DVector::from_fn(PARENTS.len(), |_, _| crate::geometry::lcg(&mut state));
            let (a, b) = (tree.factor(m).unwrap(), tree.factor(g).unwrap());
            assert_eq!(a.ld.vals, b.ld.vals);
            assert_eq!(a.solve(&rhs), b.solve(&rhs));
        }
        // A pivot that is not positive, inside a chain and outside, is refused by both.
        for k in [3, 7, 18, 22] {
            let mut m = matrix(&chains, &mut state);
            m.vals[chains.adr[k]] = -1.0;
            let g = TreeMatrix {
                vals: m.vals.clone(),
                shape: general.clone(),
            };
            assert!(tree.factor(m).is_none() && tree.factor(g).is_none(), "{k}");
        }
    }
}
