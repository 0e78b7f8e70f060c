//! METIS' nested-dissection ordering (`METIS_NodeND`) of a graph, behind one
//! safe function: the workspace's only call into C for the numerics, kept out
//! of `nlmode` (which forbids `unsafe`). METIS 5 and GKlib are compiled from
//! the sources vendored by the `metis-sys` crate (32-bit indices).

/// The nested-dissection order of the undirected graph of `n = weights.len()`
/// vertices in compressed rows (neighbours of `v` at `adj[xadj[v]..xadj[v +
/// 1]]`, both directions stored, no self-loops) with vertex weights:
/// `perm[new] = old`. `None` when an index does not fit METIS' 32-bit
/// integers, the arrays are inconsistent, or METIS reports an error.
pub fn node_nd(xadj: &[usize], adj: &[usize], weights: &[usize]) -> Option<Vec<usize>> {
    use metis_sys as m;
    let n = weights.len();
    if xadj.len() != n + 1 || xadj[n] != adj.len() || xadj.windows(2).any(|w| w[0] > w[1]) {
        return None;
    }
    if adj.iter().any(|&v| v >= n) {
        return None;
    }
    if n == 0 {
        return Some(Vec::new());
    }
    let idx = |v: &[usize]| -> Option<Vec<m::idx_t>> {
        v.iter().map(|&x| m::idx_t::try_from(x).ok()).collect()
    };
    let (mut xadj, mut adj, mut vwgt) = (idx(xadj)?, idx(adj)?, idx(weights)?);
    let mut nvtxs = m::idx_t::try_from(n).ok()?;
    let mut options = [0 as m::idx_t; m::METIS_NOPTIONS as usize];
    // SAFETY: `options` has the METIS_NOPTIONS entries METIS writes.
    unsafe { m::METIS_SetDefaultOptions(options.as_mut_ptr()) };
    options[m::moptions_et_METIS_OPTION_NUMBERING as usize] = 0;
    let (mut perm, mut iperm) = (vec![0 as m::idx_t; n], vec![0 as m::idx_t; n]);
    // SAFETY: a checked CSR graph of `nvtxs` vertices (`xadj` has nvtxs + 1
    // non-decreasing entries ending at adj.len(), every neighbour in range),
    // `vwgt`, `perm` and `iperm` have nvtxs entries; METIS reads the graph and
    // the options and writes only `perm` and `iperm`.
    let status = unsafe {
        m::METIS_NodeND(
            &mut nvtxs,
            xadj.as_mut_ptr(),
            adj.as_mut_ptr(),
            vwgt.as_mut_ptr(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    if status != m::rstatus_et_METIS_OK {
        return None;
    }
    let perm: Vec<usize> = perm
        .into_iter()
        .map(|p| usize::try_from(p).ok())
        .collect::<Option<_>>()?;
    // a permutation of 0..n
    let mut seen = vec![false; n];
    for &p in &perm {
        if p >= n || std::mem::replace(&mut seen[p], true) {
            return None;
        }
    }
    Some(perm)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_path_is_split_in_the_middle() {
        // 0 - 1 - 2 - 3 - 4
        let xadj = [0, 1, 3, 5, 7, 8];
        let adj = [1, 0, 2, 1, 3, 2, 4, 3];
        let p = super::node_nd(&xadj, &adj, &[1; 5]).unwrap();
        let mut s = p.clone();
        s.sort();
        assert_eq!(s, vec![0, 1, 2, 3, 4]);
        assert!(super::node_nd(&xadj, &adj[..7], &[1; 5]).is_none());
    }
}
