//! Dense matrices that are block-diagonal up to a permutation: a scene's coordinates fall into
//! groups that no nonzero entry joins (one per free-moving tree of bodies in a mass matrix; one
//! per island of trees that no pair in reach or constraint couples in a Newton Jacobian), and
//! the inverse is block-diagonal over the same groups. Inverting block by block costs
//! `Σ b³` instead of `n³`: MuJoCo's 300 leaves (1,800 velocities) took seconds per inverse
//! whole, and 22 humanoids' Newton Jacobian (594 velocities) a tenth of a step.

use nalgebra::DMatrix;

/// The groups of coordinates of the square `m` that no nonzero entry joins (`m[(a, b)]` or
/// `m[(b, a)]` nonzero puts `a` and `b` in one group), each in increasing order, ordered by
/// their first coordinate.
pub fn coupled_groups(m: &DMatrix<f64>) -> Vec<Vec<usize>> {
    let n = m.nrows();
    assert_eq!(m.ncols(), n, "a square matrix");
    // Union-find over the nonzero entries, each group's root its smallest coordinate.
    let mut root: Vec<usize> = (0..n).collect();
    fn find(root: &mut [usize], mut i: usize) -> usize {
        while root[i] != i {
            root[i] = root[root[i]];
            i = root[i];
        }
        i
    }
    for a in 0..n {
        for b in 0..a {
            if m[(a, b)] != 0.0 || m[(b, a)] != 0.0 {
                let (ra, rb) = (find(&mut root, a), find(&mut root, b));
                root[ra.max(rb)] = ra.min(rb);
            }
        }
    }
    let mut slot = vec![usize::MAX; n];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        let r = find(&mut root, i);
        if slot[r] == usize::MAX {
            slot[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[slot[r]].push(i);
    }
    groups
}

/// The inverse of the square `m`, each group of [`coupled_groups`] inverted by `invert` on its
/// own block (zeros between groups). `None` when `invert` fails on a block. With one group it
/// is `invert(m)`, to the bit.
pub fn block_inverse(
    m: &DMatrix<f64>,
    invert: impl Fn(DMatrix<f64>) -> Option<DMatrix<f64>>,
) -> Option<DMatrix<f64>> {
    let groups = coupled_groups(m);
    if groups.len() == 1 {
        return invert(m.clone());
    }
    let n = m.nrows();
    let mut inv = DMatrix::zeros(n, n);
    for idx in &groups {
        let block = m.select_rows(idx).select_columns(idx);
        let block_inv = invert(block)?;
        for (i, &a) in idx.iter().enumerate() {
            for (j, &b) in idx.iter().enumerate() {
                inv[(a, b)] = block_inv[(i, j)];
            }
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A matrix of three islands interleaved ({0, 3}, {1, 4, 5} joined only through an entry
    /// above the diagonal, {2}): its groups, and its block inverse against the whole LU
    /// inverse (to rounding: 1e-14 of entries of order one).
    #[test]
    fn interleaved_islands_invert_block_by_block_as_the_whole() {
        let mut m = DMatrix::<f64>::identity(6, 6) * 3.0;
        m[(0, 3)] = 0.7;
        m[(3, 0)] = -0.4;
        m[(1, 4)] = 0.9;
        m[(4, 5)] = -1.1;
        m[(2, 2)] = 5.0;
        assert_eq!(coupled_groups(&m), vec![vec![0, 3], vec![1, 4, 5], vec![2]]);
        let lu = |b: DMatrix<f64>| b.lu().try_inverse();
        let blocks = block_inverse(&m, lu).unwrap();
        let whole = m.clone().lu().try_inverse().unwrap();
        assert!((&blocks - &whole).amax() < 1e-14, "{blocks} {whole}");
        assert!((&m * &blocks - DMatrix::identity(6, 6)).amax() < 1e-14);
        // A singular island makes the whole singular.
        m[(2, 2)] = 0.0;
        assert!(block_inverse(&m, lu).is_none());
        // One group: the whole inverse, to the bit.
        let full = DMatrix::from_fn(3, 3, |i, j| if i == j { 2.0 } else { 0.3 });
        assert_eq!(block_inverse(&full, lu), full.clone().lu().try_inverse());
    }
}
