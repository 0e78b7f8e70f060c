//! METIS' nested-dissection ordering (`METIS_NodeND`) and vertex separator
//! (`METIS_ComputeVertexSeparator`) of a graph, behind safe functions: the
//! workspace's only calls into C for the numerics, kept out of `nlmode`
//! (which forbids `unsafe`). METIS 5 and GKlib are compiled from the sources
//! vendored by the `metis-sys` crate (32-bit indices).
//!
//! METIS keeps the state of its random generator in globals (GKlib's
//! `random.c`, seeded at each call): two calls at once from different threads
//! would race on it, and their results would depend on the timing. Every
//! call here holds [`METIS`] for its duration.

/// Held during every call into METIS (module docs).
static METIS: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The nested-dissection order of the undirected graph of `n = weights.len()`
/// vertices in compressed rows (neighbours of `v` at `adj[xadj[v]..xadj[v +
/// 1]]`, both directions stored, no self-loops) with vertex weights:
/// `perm[new] = old`. `None` when an index does not fit METIS' 32-bit
/// integers, the arrays are inconsistent, or METIS reports an error.
pub fn node_nd(xadj: &[usize], adj: &[usize], weights: &[usize]) -> Option<Vec<usize>> {
    use metis_sys as m;
    let n = weights.len();
    let mut g = Graph32::new(xadj, adj, weights)?;
    if n == 0 {
        return Some(Vec::new());
    }
    let (mut perm, mut iperm) = (vec![0 as m::idx_t; n], vec![0 as m::idx_t; n]);
    // SAFETY: a checked CSR graph of `nvtxs` vertices (`xadj` has nvtxs + 1
    // non-decreasing entries ending at adj.len(), every neighbour in range),
    // `vwgt`, `perm` and `iperm` have nvtxs entries; METIS reads the graph and
    // the options and writes only `perm` and `iperm`.
    let _one_at_a_time = METIS.lock().unwrap_or_else(|e| e.into_inner());
    let status = unsafe {
        m::METIS_NodeND(
            &mut g.nvtxs,
            g.xadj.as_mut_ptr(),
            g.adj.as_mut_ptr(),
            g.vwgt.as_mut_ptr(),
            g.options.as_mut_ptr(),
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

/// METIS' vertex separator of the graph of [`node_nd`]'s arguments (the
/// bisection at the top of its nested dissection), the smallest of `tries`
/// (`METIS_OPTION_NSEPS`): `part[v]` is 0 or 1 for the two sides, 2 for the
/// separator; no edge joins side 0 to side 1. `None` as for [`node_nd`].
pub fn vertex_separator(
    xadj: &[usize],
    adj: &[usize],
    weights: &[usize],
    tries: usize,
) -> Option<Vec<u8>> {
    use metis_sys as m;
    let n = weights.len();
    let mut g = Graph32::new(xadj, adj, weights)?;
    if n == 0 {
        return Some(Vec::new());
    }
    g.options[m::moptions_et_METIS_OPTION_NSEPS as usize] =
        m::idx_t::try_from(tries.max(1)).ok()?;
    let mut part = vec![0 as m::idx_t; n];
    let mut sepsize: m::idx_t = 0;
    // SAFETY: a checked CSR graph of `nvtxs` vertices (as in `node_nd`),
    // `vwgt` and `part` have nvtxs entries; METIS reads the graph and the
    // options and writes only `sepsize` and `part`.
    let _one_at_a_time = METIS.lock().unwrap_or_else(|e| e.into_inner());
    let status = unsafe {
        m::METIS_ComputeVertexSeparator(
            &mut g.nvtxs,
            g.xadj.as_mut_ptr(),
            g.adj.as_mut_ptr(),
            g.vwgt.as_mut_ptr(),
            g.options.as_mut_ptr(),
            &mut sepsize,
            part.as_mut_ptr(),
        )
    };
    if status != m::rstatus_et_METIS_OK {
        return None;
    }
    part.into_iter()
        .map(|p| u8::try_from(p).ok().filter(|&p| p <= 2))
        .collect()
}

/// A graph as METIS takes it: 32-bit arrays, the vertex count, and the
/// default options with 0-based numbering.
struct Graph32 {
    xadj: Vec<metis_sys::idx_t>,
    adj: Vec<metis_sys::idx_t>,
    vwgt: Vec<metis_sys::idx_t>,
    nvtxs: metis_sys::idx_t,
    options: [metis_sys::idx_t; metis_sys::METIS_NOPTIONS as usize],
}

impl Graph32 {
    /// `None` when inconsistent (`xadj` of `n + 1` non-decreasing entries
    /// ending at `adj.len()`, neighbours below `n`) or beyond 32 bits.
    fn new(xadj: &[usize], adj: &[usize], weights: &[usize]) -> Option<Self> {
        use metis_sys as m;
        let n = weights.len();
        if xadj.len() != n + 1 || xadj[n] != adj.len() || xadj.windows(2).any(|w| w[0] > w[1]) {
            return None;
        }
        if adj.iter().any(|&v| v >= n) {
            return None;
        }
        let idx = |v: &[usize]| -> Option<Vec<m::idx_t>> {
            v.iter().map(|&x| m::idx_t::try_from(x).ok()).collect()
        };
        let mut options = [0 as m::idx_t; m::METIS_NOPTIONS as usize];
        // SAFETY: `options` has the METIS_NOPTIONS entries METIS writes.
        unsafe { m::METIS_SetDefaultOptions(options.as_mut_ptr()) };
        options[m::moptions_et_METIS_OPTION_NUMBERING as usize] = 0;
        Some(Self {
            xadj: idx(xadj)?,
            adj: idx(adj)?,
            vwgt: idx(weights)?,
            nvtxs: m::idx_t::try_from(n).ok()?,
            options,
        })
    }
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

    /// The graph of a `k x k` grid (4 neighbours).
    fn grid(k: usize) -> (Vec<usize>, Vec<usize>) {
        let (mut xadj, mut adj) = (vec![0], Vec::new());
        for i in 0..k {
            for j in 0..k {
                let v = i * k + j;
                if i > 0 {
                    adj.push(v - k);
                }
                if j > 0 {
                    adj.push(v - 1);
                }
                if j + 1 < k {
                    adj.push(v + 1);
                }
                if i + 1 < k {
                    adj.push(v + k);
                }
                xadj.push(adj.len());
            }
        }
        (xadj, adj)
    }

    #[test]
    fn a_grid_is_separated() {
        // a 20 x 20 grid graph: a separator of about one line
        let k = 20;
        let (xadj, adj) = grid(k);
        let part = super::vertex_separator(&xadj, &adj, &[1; 400], 2).unwrap();
        let count = |p: u8| part.iter().filter(|&&q| q == p).count();
        assert!((k..=2 * k).contains(&count(2)), "separator {}", count(2));
        assert!(count(0) >= 150 && count(1) >= 150);
        for v in 0..400 {
            for &u in &adj[xadj[v]..xadj[v + 1]] {
                assert!(part[v] + part[u] != 1, "edge {v}-{u} across the separator");
            }
        }
        assert!(super::vertex_separator(&xadj, &adj[..5], &[1; 400], 1).is_none());
    }

    #[test]
    fn calls_at_once_give_the_results_of_calls_one_by_one() {
        let (xadj, adj) = grid(60);
        let w = vec![1; 3600];
        let nd = super::node_nd(&xadj, &adj, &w).unwrap();
        let sep = super::vertex_separator(&xadj, &adj, &w, 2).unwrap();
        std::thread::scope(|s| {
            let runs: Vec<_> = (0..4)
                .map(|_| {
                    s.spawn(|| {
                        (0..5)
                            .map(|_| {
                                (
                                    super::node_nd(&xadj, &adj, &w).unwrap(),
                                    super::vertex_separator(&xadj, &adj, &w, 2).unwrap(),
                                )
                            })
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            for r in runs {
                for (p, q) in r.join().unwrap() {
                    assert!(p == nd && q == sep, "a result that depends on the timing");
                }
            }
        });
    }
}
