//! Fill-reducing orderings of the sparse Cholesky factorisation
//! ([`super::sparse::SymbolicFactor`]): faer's approximate minimum degree
//! (AMD), or a nested dissection by METIS (`METIS_NodeND` through the
//! workspace's `metis-nd` crate, which builds the C sources vendored by
//! `metis-sys`; cargo feature `metis` of nlmode, on by default).
//!
//! Nested dissection orders a 3-D (or thick 2-D) FE mesh with far less fill
//! than AMD (`docs/performance.md`: the measured `nnz(L)`, factor time and
//! memory at 10^5 to 10^6 DOFs). METIS is given the graph of the matrix
//! compressed to its supervariables (DOFs with the same closed neighbourhood,
//! i.e. the DOFs of one FE node), weighted by their sizes: a third of the
//! vertices and a ninth of the edges of the DOF graph of a solid model. nlmode
//! itself stays free of `unsafe` and FFI; built without the feature,
//! `nested-dissection` is refused by name and `auto` is AMD.
use super::sparse::SparseMatrix;
use std::collections::HashMap;

/// The fill-reducing ordering of the large-model path (`[structure] ordering`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Ordering {
    /// Nested dissection from [`AUTO_ND_MIN_DOF`] DOFs on (where built with
    /// METIS), AMD below.
    #[default]
    Auto,
    /// faer's approximate minimum degree.
    Amd,
    /// METIS' nested dissection.
    NestedDissection,
}

/// Smallest model that [`Ordering::Auto`] orders by nested dissection: below,
/// AMD's fill is as small and its ordering faster (`docs/performance.md`).
pub const AUTO_ND_MIN_DOF: usize = 20_000;

/// Whether this build has the nested dissection (cargo feature `metis`).
pub const NESTED_DISSECTION_AVAILABLE: bool = cfg!(feature = "metis");

impl Ordering {
    /// The key's value (`"amd"`, `"nested-dissection"`, `"auto"`).
    pub fn name(self) -> &'static str {
        match self {
            Ordering::Auto => "auto",
            Ordering::Amd => "amd",
            Ordering::NestedDissection => "nested-dissection",
        }
    }

    /// The ordering used for an `n x n` matrix: `Auto` resolved.
    pub fn resolve(self, n: usize) -> Ordering {
        match self {
            Ordering::Auto if NESTED_DISSECTION_AVAILABLE && n >= AUTO_ND_MIN_DOF => {
                Ordering::NestedDissection
            }
            Ordering::Auto => Ordering::Amd,
            o => o,
        }
    }
}

/// The undirected graph of a symmetric pattern (lower triangle read, no
/// self-loops) in compressed rows: neighbours of `v` at
/// `adj[xadj[v]..xadj[v + 1]]`, ascending.
pub(crate) struct Graph {
    pub xadj: Vec<usize>,
    pub adj: Vec<usize>,
}

impl Graph {
    /// The graph of `a`'s lower triangle (`r > c`), mirrored.
    pub fn of_lower(a: &SparseMatrix) -> Graph {
        let n = a.ncols();
        let sym = a.symbolic();
        let ri = sym.row_idx();
        let lower = |c: usize| sym.col_range(c).map(move |p| ri[p]).filter(move |&r| r > c);
        let mut deg = vec![0usize; n];
        for c in 0..n {
            for r in lower(c) {
                deg[r] += 1;
                deg[c] += 1;
            }
        }
        let mut xadj = vec![0usize; n + 1];
        for v in 0..n {
            xadj[v + 1] = xadj[v] + deg[v];
        }
        let mut adj = vec![0usize; xadj[n]];
        let mut pos = xadj[..n].to_vec();
        // the neighbours below v first (columns c < v ascending), then those above
        for c in 0..n {
            for r in lower(c) {
                adj[pos[r]] = c;
                pos[r] += 1;
            }
        }
        for c in 0..n {
            for r in lower(c) {
                adj[pos[c]] = r;
                pos[c] += 1;
            }
        }
        Graph { xadj, adj }
    }

    fn n(&self) -> usize {
        self.xadj.len() - 1
    }

    fn neighbours(&self, v: usize) -> &[usize] {
        &self.adj[self.xadj[v]..self.xadj[v + 1]]
    }

    /// Whether `u` and `v` have the same closed neighbourhood (`N(u) + u`).
    fn indistinguishable(&self, u: usize, v: usize) -> bool {
        let (a, b) = (self.neighbours(u), self.neighbours(v));
        if a.len() != b.len() {
            return false;
        }
        // N(u) + u == N(v) + v  <=>  N(u) - v == N(v) - u and u ~ v
        let mut ia = a.iter().copied().filter(|&x| x != v);
        let mut ib = b.iter().copied().filter(|&x| x != u);
        let adjacent = a.binary_search(&v).is_ok();
        adjacent
            && loop {
                match (ia.next(), ib.next()) {
                    (None, None) => break true,
                    (x, y) if x == y => {}
                    _ => break false,
                }
            }
    }

    /// The supervariables: `group[v]` of each vertex and the members of each
    /// group (ascending), groups numbered by their first member.
    pub fn supervariables(&self) -> (Vec<usize>, Vec<Vec<usize>>) {
        let n = self.n();
        let hash = |v: usize| {
            // order-independent hash of the closed neighbourhood
            let mix =
                |x: usize| (x as u64 ^ 0x9e37_79b9_7f4a_7c15).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            self.neighbours(v)
                .iter()
                .fold(mix(v), |h, &x| h.wrapping_add(mix(x)))
        };
        let mut group = Vec::with_capacity(n);
        let mut members: Vec<Vec<usize>> = Vec::new();
        let mut by_hash: HashMap<(u64, usize), Vec<usize>> = HashMap::new();
        for v in 0..n {
            let cands = by_hash
                .entry((hash(v), self.neighbours(v).len()))
                .or_default();
            match cands
                .iter()
                .copied()
                .find(|&g| self.indistinguishable(members[g][0], v))
            {
                Some(g) => {
                    group.push(g);
                    members[g].push(v);
                }
                None => {
                    group.push(members.len());
                    cands.push(members.len());
                    members.push(vec![v]);
                }
            }
        }
        (group, members)
    }
}

/// The nested-dissection permutation of `a`'s pattern (`perm[new] = old`,
/// faer's and METIS' convention), `None` where METIS fails or is not built in.
pub fn nested_dissection(a: &SparseMatrix) -> Option<Vec<usize>> {
    let g = Graph::of_lower(a);
    let (group, members) = g.supervariables();
    let ng = members.len();
    // the compressed graph: a group's neighbours are its first member's, as groups
    let mut xadj = Vec::with_capacity(ng + 1);
    let mut adj = Vec::new();
    let mut seen = vec![usize::MAX; ng];
    xadj.push(0);
    for (gi, m) in members.iter().enumerate() {
        seen[gi] = gi;
        for &x in g.neighbours(m[0]) {
            let h = group[x];
            if seen[h] != gi {
                seen[h] = gi;
                adj.push(h);
            }
        }
        xadj.push(adj.len());
    }
    drop(g);
    let weights: Vec<usize> = members.iter().map(Vec::len).collect();
    let graph = Compressed { xadj, adj, weights };
    let perm = order_graph(&graph, SPLIT_MIN_VERTICES)?;
    let mut out = Vec::with_capacity(a.ncols());
    for gi in perm {
        out.extend_from_slice(&members[gi]);
    }
    Some(out)
}

/// A compressed graph of [`nested_dissection`]: both directions of each edge
/// in rows (`adj[xadj[v]..xadj[v + 1]]`), vertex weights.
struct Compressed {
    xadj: Vec<usize>,
    adj: Vec<usize>,
    weights: Vec<usize>,
}

/// From this many vertices of the compressed graph on, [`nested_dissection`]
/// takes the top vertex separator itself, the smaller of
/// [`SEPARATOR_TRIES`] by METIS (`METIS_ComputeVertexSeparator`), and orders
/// each side by `METIS_NodeND`, the separator last; below, `METIS_NodeND` on
/// the whole graph. The factor's two top subtrees are then about equal, as
/// the parallel factorisation and solves share them ([`super::supernodal`]).
/// On the benchmark plate the factor has fewer entries at 10^5 DOFs (39.9
/// against 42.2 million; the factorisation took 0.62-0.70 s against
/// 0.88-0.93 s) and as many at 10^6 (582.1 against 581.2 million), for about
/// the same ordering time (0.42 against 0.39 s; 5.6 against 5.2 s). Splitting
/// further was tried: more fill at 10^6 (591 million with one separator per
/// level), or 35 % more ordering time (567 million with two). The sides are
/// ordered one after the other: METIS keeps its random generator's state in
/// globals (GKlib's `random.c`), so two calls at once would race.
pub const SPLIT_MIN_VERTICES: usize = 8192;

/// Separators METIS computes for the top split, the smallest kept.
pub const SEPARATOR_TRIES: usize = 2;

/// The nested-dissection order of `g`'s vertices (`perm[new] = old`), split at
/// the top separator from `split_min` vertices on.
fn order_graph(g: &Compressed, split_min: usize) -> Option<Vec<usize>> {
    let n = g.weights.len();
    if n < split_min.max(2) {
        return metis_node_nd(&g.xadj, &g.adj, &g.weights);
    }
    let part = metis_vertex_separator(&g.xadj, &g.adj, &g.weights, SEPARATOR_TRIES)?;
    let (s0, s1) = (side(g, &part, 0), side(g, &part, 1));
    if s0.1.weights.is_empty() || s1.1.weights.is_empty() {
        // no split (a graph METIS cannot bisect): its own ordering
        return metis_node_nd(&g.xadj, &g.adj, &g.weights);
    }
    let mut out = Vec::with_capacity(n);
    for (members, sub) in [s0, s1] {
        let p = metis_node_nd(&sub.xadj, &sub.adj, &sub.weights)?;
        out.extend(p.into_iter().map(|i| members[i]));
    }
    out.extend((0..n).filter(|&v| part[v] == 2));
    Some(out)
}

/// The vertices of `g` on side `p` of `part` and the subgraph they induce.
fn side(g: &Compressed, part: &[u8], p: u8) -> (Vec<usize>, Compressed) {
    let members: Vec<usize> = (0..part.len()).filter(|&v| part[v] == p).collect();
    let mut local = vec![usize::MAX; part.len()];
    for (i, &v) in members.iter().enumerate() {
        local[v] = i;
    }
    let mut sub = Compressed {
        xadj: Vec::with_capacity(members.len() + 1),
        adj: Vec::new(),
        weights: members.iter().map(|&v| g.weights[v]).collect(),
    };
    sub.xadj.push(0);
    for &v in &members {
        sub.adj.extend(
            g.adj[g.xadj[v]..g.xadj[v + 1]]
                .iter()
                .filter(|&&u| part[u] == p)
                .map(|&u| local[u]),
        );
        sub.xadj.push(sub.adj.len());
    }
    (members, sub)
}

#[cfg(feature = "metis")]
fn metis_node_nd(xadj: &[usize], adj: &[usize], weights: &[usize]) -> Option<Vec<usize>> {
    metis_nd::node_nd(xadj, adj, weights)
}

#[cfg(not(feature = "metis"))]
fn metis_node_nd(_: &[usize], _: &[usize], _: &[usize]) -> Option<Vec<usize>> {
    None
}

#[cfg(feature = "metis")]
fn metis_vertex_separator(
    xadj: &[usize],
    adj: &[usize],
    weights: &[usize],
    tries: usize,
) -> Option<Vec<u8>> {
    metis_nd::vertex_separator(xadj, adj, weights, tries)
}

#[cfg(not(feature = "metis"))]
fn metis_vertex_separator(_: &[usize], _: &[usize], _: &[usize], _: usize) -> Option<Vec<u8>> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::structure::sparse::sparse_from_triplets;

    #[test]
    fn supervariables_of_a_two_dof_chain() {
        // 3 nodes of 2 DOFs each in a chain: nodes (0,1), (2,3), (4,5)
        let mut t = Vec::new();
        for a in 0..6usize {
            for b in 0..6usize {
                if (a / 2).abs_diff(b / 2) <= 1 && a >= b {
                    t.push((a, b, 1.0));
                }
            }
        }
        let a = sparse_from_triplets(6, &t).unwrap();
        let g = Graph::of_lower(&a);
        assert_eq!(g.neighbours(2), &[0, 1, 3, 4, 5]);
        let (group, members) = g.supervariables();
        assert_eq!(group, vec![0, 0, 1, 1, 2, 2]);
        assert_eq!(members, vec![vec![0, 1], vec![2, 3], vec![4, 5]]);
        if NESTED_DISSECTION_AVAILABLE {
            let mut p = nested_dissection(&a).unwrap();
            // the middle node is the separator: ordered last
            assert_eq!(&p[4..], &[2, 3]);
            p.sort();
            assert_eq!(p, (0..6).collect::<Vec<_>>());
        }
    }

    /// A small solid model (a cantilever steel block of 10 x 10 x 10
    /// hexahedra, 3,630 DOFs): the nested dissection gives AMD's eigenvalues
    /// to 1e-10 and a valid permutation (the factor's fill is measured in
    /// docs/performance.md). On the thin benchmark plate (`lambda_max /
    /// lambda_1` about 1e9) the two agree to the factorisations' rounding,
    /// about 1e-9.
    #[test]
    fn nested_dissection_gives_the_eigenvalues_of_amd() {
        use crate::structure::lanczos::{modal_factor, modes, Pencil};
        use crate::structure::solid::HexPlate;
        use crate::structure::sparse::SymbolicFactor;
        let block = HexPlate {
            length_m: 0.1,
            width_m: 0.1,
            thickness_m: 0.1,
            nx: 10,
            ny: 10,
            nz: 10,
            ..HexPlate::benchmark(3_000)
        };
        let (m, k) = block.assemble().unwrap();
        let pencil = Pencil {
            m: &m,
            k: &k,
            fixed: &[],
            par: faer::Par::Seq,
        };
        let lambda = |o: Ordering| {
            let s = SymbolicFactor::with_ordering(&k, o).unwrap();
            assert_eq!(s.ordering(), o);
            let f = modal_factor(&m, &k, Some(&s), faer::Par::Seq).unwrap();
            (modes(&pencil, &f, 8, "n_modes").unwrap().0, s.nnz())
        };
        let (amd, nnz_amd) = lambda(Ordering::Amd);
        if !NESTED_DISSECTION_AVAILABLE {
            let s = SymbolicFactor::with_ordering(&k, Ordering::NestedDissection).unwrap();
            assert_eq!(s.ordering(), Ordering::Amd, "AMD where METIS is missing");
            return;
        }
        let (nd, nnz_nd) = lambda(Ordering::NestedDissection);
        assert!(nnz_amd > 0 && nnz_nd > 0);
        // the eigenvalues lambda = omega^2
        for (a, b) in amd.iter().zip(&nd) {
            assert!((a * a - b * b).abs() <= 1e-10 * a * a, "{a} vs {b}");
        }
        let mut p = nested_dissection(&k).unwrap();
        p.sort();
        assert_eq!(p, (0..k.nrows()).collect::<Vec<_>>());
    }

    /// The graph of a `k x k` grid (4 neighbours), unit weights.
    fn grid_graph(k: usize) -> Compressed {
        let (mut xadj, mut adj) = (vec![0], Vec::new());
        for i in 0..k {
            for j in 0..k {
                for (di, dj) in [(-1i64, 0i64), (0, -1), (0, 1), (1, 0)] {
                    let (p, q) = (i as i64 + di, j as i64 + dj);
                    if (0..k as i64).contains(&p) && (0..k as i64).contains(&q) {
                        adj.push(p as usize * k + q as usize);
                    }
                }
                xadj.push(adj.len());
            }
        }
        Compressed {
            xadj,
            adj,
            weights: vec![1; k * k],
        }
    }

    /// The split ordering is a permutation, and a dissection: the vertices
    /// before the top separator fall in two runs with no edge between (the
    /// separator's property, tested in `metis-nd`), each in METIS' order.
    #[test]
    fn split_ordering_is_a_nested_dissection() {
        if !NESTED_DISSECTION_AVAILABLE {
            return;
        }
        let g = grid_graph(40);
        let n = g.weights.len();
        let p = order_graph(&g, 100).unwrap();
        let mut sorted = p.clone();
        sorted.sort();
        assert_eq!(sorted, (0..n).collect::<Vec<_>>());
        // the top split again, as order_graph takes it (METIS is deterministic)
        let part = metis_vertex_separator(&g.xadj, &g.adj, &g.weights, SEPARATOR_TRIES).unwrap();
        let count = |q: u8| part.iter().filter(|&&x| x == q).count();
        let (n0, n1) = (count(0), count(1));
        assert!(n0 > n / 4 && n1 > n / 4, "sides {n0} {n1}");
        assert!(p[..n0].iter().all(|&v| part[v] == 0));
        assert!(p[n0..n0 + n1].iter().all(|&v| part[v] == 1));
        assert!(p[n0 + n1..].iter().all(|&v| part[v] == 2));
        // below the threshold: METIS' own ordering
        assert_eq!(
            order_graph(&g, n + 1).unwrap(),
            metis_node_nd(&g.xadj, &g.adj, &g.weights).unwrap()
        );
    }

    /// A 3-D grid of 22^3 DOFs, above [`SPLIT_MIN_VERTICES`]: the split
    /// nested dissection factorises it with less fill than AMD, and solves.
    #[test]
    fn split_nested_dissection_factorises_a_3d_grid() {
        use crate::structure::sparse::{sym_mul, SparseCholesky, SymbolicFactor, Xorshift};
        if !NESTED_DISSECTION_AVAILABLE {
            return;
        }
        let k = 22;
        let id = |i: usize, j: usize, l: usize| (i * k + j) * k + l;
        let mut t = Vec::new();
        for i in 0..k {
            for j in 0..k {
                for l in 0..k {
                    t.push((id(i, j, l), id(i, j, l), 6.5));
                    for (p, q, r) in [(i + 1, j, l), (i, j + 1, l), (i, j, l + 1)] {
                        if p < k && q < k && r < k {
                            t.push((id(i, j, l), id(p, q, r), -1.0));
                            t.push((id(p, q, r), id(i, j, l), -1.0));
                        }
                    }
                }
            }
        }
        let a = sparse_from_triplets(k * k * k, &t).unwrap();
        assert!(a.nrows() >= SPLIT_MIN_VERTICES);
        let nd = SymbolicFactor::with_ordering(&a, Ordering::NestedDissection).unwrap();
        let amd = SymbolicFactor::with_ordering(&a, Ordering::Amd).unwrap();
        assert_eq!(nd.ordering(), Ordering::NestedDissection);
        assert!(
            nd.nnz() < amd.nnz(),
            "nnz(L) {} against AMD's {}",
            nd.nnz(),
            amd.nnz()
        );
        let f = SparseCholesky::with_symbolic(&nd, &a, faer::Par::rayon(2)).unwrap();
        let b = Xorshift(0x0dd_5eed).block(a.nrows(), 2);
        let mut x = b.clone();
        f.solve_in_place(&mut x);
        let r = (sym_mul(&a, &x) - &b).amax();
        assert!(r <= 1e-12 * b.amax(), "residual {r}");
    }

    #[test]
    fn auto_resolves_by_size() {
        assert_eq!(Ordering::Auto.resolve(100), Ordering::Amd);
        assert_eq!(Ordering::Amd.resolve(1 << 20), Ordering::Amd);
        let big = Ordering::Auto.resolve(AUTO_ND_MIN_DOF);
        assert_eq!(
            big == Ordering::NestedDissection,
            NESTED_DISSECTION_AVAILABLE
        );
    }
}
