//! The numeric factorisation `P A P^T = L L^T` of a supernodal Cholesky
//! factor (faer's symbolic factorisation and storage,
//! [`super::sparse::SparseCholesky`]) and the solves with it: `L z = P b`,
//! then `L^T y = z`, `x = P^T y`; independent subtrees of the elimination
//! tree in parallel in both.
//!
//! The factorisation ([`SolvePlan::factorize`]) is left-looking as faer's:
//! a supernode gathers the updates `-L_d L_d^T` of the supernodes below it
//! that have rows in it, then factors its diagonal block (faer's dense
//! Cholesky) and solves its off-diagonal block (faer's triangular solve). The
//! parts' supernodes are factored in parallel (each part's updates come from
//! its own subtrees only), then the top ones with faer's threads in their
//! larger dense blocks. Hand-written for the same reason as the solves: faer's
//! numeric factorisation visits the supernodes one after the other and took
//! as long on 2 threads as on 1 at 10^5 DOFs (1.10 against 1.12 s).
//!
//! Hand-written around faer's dense kernels instead of faer's supernodal
//! solve (performance): faer visits the supernodes one after the other and
//! gives its threads to the dense products inside each supernode, which at the
//! Lanczos iteration's 3 right-hand sides are too small to share: its solves
//! ran slower with 2 threads than with 1 (10^5 and 3·10^5 DOFs). A solve reads
//! the whole factor twice and is bound by memory bandwidth, which two cores
//! double on the benchmark machine. Here the supernodes are split once per
//! symbolic factorisation ([`SolvePlan`]) into [`PARTS`] groups of whole
//! subtrees (about equal factor entries, a subtree-to-thread mapping) and the
//! ancestors of those subtrees (the top separators of a nested dissection):
//!
//! - forward (`L z = b`): each part solves its subtrees, the updates of the
//!   ancestors' rows summed in a block of its own; the blocks are added in
//!   part order, then the ancestors are solved;
//! - backward (`L^T y = z`): the ancestors first, then each part's subtrees,
//!   reading the ancestors' rows.
//!
//! The right-hand sides' rows are regrouped for the solve: each part's rows
//! one after the other in the part's order, and the top's, so that a
//! supernode finds each row of its pattern at a place the plan holds
//! ([`SolvePlan::new`]: one table lookup per row; before, three lookups and
//! a match per row took a tenth of a solve: 85 against 77 ms for 3
//! right-hand sides at 10^5 DOFs on one thread, best of 30). The forward
//! update `L_bs x_s` is formed by columns, so that faer's product runs along
//! the pattern's rows rather than along the few right-hand sides (77 against
//! 70 ms; 42 against 38 ms on two threads); by columns in the backward
//! solve, or with the right-hand sides copied by columns, was slower.
//!
//! The grouping does not depend on the thread count (so neither does the
//! rounding); with one thread the parts run one after the other.
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::sparse::SparseColMatRef;
use faer::{Accum, MatMut, MatRef, Par};

/// Groups of subtrees solved independently (fixed, so that the rounding does
/// not depend on the thread count; two is the benchmark machine's core count).
pub const PARTS: usize = 2;

/// A subtree is split further while it holds more than this factor times an
/// equal share of the entries still in subtrees.
const SPLIT_SLACK: f64 = 1.05;

/// Where a supernode is solved: in a part, or among the ancestors.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Owner {
    /// Part, position in its list.
    Part(usize, usize),
    /// The top.
    Top,
}

impl Owner {
    /// The owner's block of the rows a solve holds ([`SolvePlan::held_rows`]).
    fn block(self) -> usize {
        match self {
            Owner::Part(p, _) => p,
            Owner::Top => PARTS,
        }
    }
}

/// The split of a factor's supernodes (module docs).
#[derive(Debug)]
pub struct SolvePlan {
    /// Per part, its supernodes (whole subtrees), ascending.
    parts: Vec<Vec<usize>>,
    /// The supernodes in no part (ancestors of the parts' subtrees), ascending.
    top: Vec<usize>,
    /// Rows of each part's supernodes, then of the top's (`PARTS + 1`).
    held_rows: Vec<usize>,
    owner: Vec<Owner>,
    /// Each (permuted) row's place among its owner's rows (a part's rows in
    /// the part's order, or the top's): where the solves hold it.
    local: Vec<u32>,
    /// Per supernode, how many of its pattern's rows its owner holds (the
    /// first ones; the rest are the top's).
    own: Vec<u32>,
    /// The supernodes that update each supernode in the factorisation (those
    /// with a row of it in their pattern), ascending: `updaters[ptr[s]..ptr[s + 1]]`.
    updaters: Vec<u32>,
    updaters_ptr: Vec<usize>,
}

impl SolvePlan {
    /// The plan of `sym`; `None` for a factor too large for 32-bit supernode
    /// numbers or with an inconsistent tree (the solve is then faer's).
    pub fn new(sym: &SymbolicSupernodalCholesky<usize>) -> Option<Self> {
        let ns = sym.n_supernodes();
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        let n = end.last().copied().unwrap_or(0);
        if ns >= u32::MAX as usize {
            return None;
        }
        let mut supernode_of_row = vec![0u32; n];
        let mut children = vec![Vec::new(); ns];
        let mut roots = Vec::new();
        let mut sub = vec![0.0f64; ns];
        for s in 0..ns {
            if begin[s] > end[s] || end[s] > n {
                return None;
            }
            supernode_of_row[begin[s]..end[s]].fill(s as u32);
            let pattern = sym.supernode(s).pattern();
            let cols = end[s] - begin[s];
            sub[s] += ((cols + pattern.len()) * cols) as f64;
        }
        // the parent: the supernode of the first off-diagonal row (children
        // come before their parents, so subtree sums accumulate in one pass)
        for s in 0..ns {
            match sym.supernode(s).pattern().iter().min() {
                Some(&r) if r < n && supernode_of_row[r] as usize > s => {
                    let p = supernode_of_row[r] as usize;
                    sub[p] += sub[s];
                    children[p].push(s);
                }
                Some(_) => return None,
                None => roots.push(s),
            }
        }
        // split the largest subtree while it is above an equal share
        let (mut cands, mut top) = (roots, Vec::new());
        for _ in 0..ns {
            let total: f64 = cands.iter().map(|&c| sub[c]).sum();
            let Some((i, &big)) = cands
                .iter()
                .enumerate()
                .max_by(|a, b| sub[*a.1].total_cmp(&sub[*b.1]).then(b.0.cmp(&a.0)))
            else {
                break;
            };
            if sub[big] <= SPLIT_SLACK * total / PARTS as f64 || children[big].is_empty() {
                break;
            }
            cands.swap_remove(i);
            top.push(big);
            cands.extend_from_slice(&children[big]);
        }
        // largest subtree first into the lightest part
        cands.sort_by(|&a, &b| sub[b].total_cmp(&sub[a]).then(a.cmp(&b)));
        let mut load = [0.0f64; PARTS];
        let mut part_of_root = Vec::with_capacity(cands.len());
        for &c in &cands {
            let p = (0..PARTS)
                .min_by(|&a, &b| load[a].total_cmp(&load[b]).then(a.cmp(&b)))
                .expect("PARTS > 0");
            load[p] += sub[c];
            part_of_root.push(p);
        }
        let mut part = vec![usize::MAX; ns];
        for (&c, &p) in cands.iter().zip(&part_of_root) {
            let mut stack = vec![c];
            while let Some(s) = stack.pop() {
                part[s] = p;
                stack.extend_from_slice(&children[s]);
            }
        }
        top.sort_unstable();
        let mut parts = vec![Vec::new(); PARTS];
        let mut owner = vec![Owner::Top; ns];
        let mut next_top = 0;
        for s in 0..ns {
            if part[s] == usize::MAX {
                if top.get(next_top) != Some(&s) {
                    return None;
                }
                next_top += 1;
            } else {
                owner[s] = Owner::Part(part[s], parts[part[s]].len());
                parts[part[s]].push(s);
            }
        }
        let (local, held_rows, own) = row_places(sym, &owner, &supernode_of_row)?;
        let (updaters, updaters_ptr) = updaters(sym, &owner, &supernode_of_row)?;
        Some(Self {
            parts,
            top,
            held_rows,
            owner,
            local,
            own,
            updaters,
            updaters_ptr,
        })
    }

    /// The right-hand sides `X` (`nc` columns) regrouped for [`SolvePlan::solve`]
    /// (module docs): `row(r, out)` writes the `nc` values of row `r` of `X`
    /// (permuted order) into `out`.
    pub fn gather(
        &self,
        llt: SupernodalLltRef<'_, usize, f64>,
        nc: usize,
        mut row: impl FnMut(usize, &mut [f64]),
    ) -> SolveRows {
        let sym = llt.symbolic();
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        let mut data = vec![0.0; self.held_rows.iter().sum::<usize>() * nc];
        for s in 0..self.owner.len() {
            let at = self.held_at(s, begin[s], nc);
            let rows = data[at..at + (end[s] - begin[s]) * nc].chunks_exact_mut(nc.max(1));
            for (r, out) in (begin[s]..end[s]).zip(rows) {
                row(r, out);
            }
        }
        SolveRows { data, nc }
    }

    /// The solution in `rows` handed back by rows: `row(r, values)` for each
    /// row `r` (permuted order) of `X`.
    pub fn scatter(
        &self,
        llt: SupernodalLltRef<'_, usize, f64>,
        rows: &SolveRows,
        mut row: impl FnMut(usize, &[f64]),
    ) {
        let sym = llt.symbolic();
        let (begin, end, nc) = (sym.supernode_begin(), sym.supernode_end(), rows.nc);
        for s in 0..self.owner.len() {
            let at = self.held_at(s, begin[s], nc);
            let vals = rows.data[at..at + (end[s] - begin[s]) * nc].chunks_exact(nc.max(1));
            for (r, v) in (begin[s]..end[s]).zip(vals) {
                row(r, v);
            }
        }
    }

    /// `X := L^{-T} Z L^{-1} X` for `X` regrouped by [`SolvePlan::gather`],
    /// where `Z` zeroes the rows from `zero_from` on (the DOFs ordered last:
    /// [`super::sparse::SparseCholesky::solve_leading_in_place`]; `zero_from
    /// = n` for a plain solve).
    pub fn solve(
        &self,
        llt: SupernodalLltRef<'_, usize, f64>,
        x: &mut SolveRows,
        zero_from: usize,
        par: Par,
    ) {
        let nc = x.nc;
        if nc == 0 {
            return;
        }
        let (mut parts, top) = self.blocks(&mut x.data, nc);
        let ctx = Ctx {
            llt,
            plan: self,
            nc,
        };
        let sym = llt.symbolic();
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        // forward: the parts, their updates of the top rows summed apart,
        // added in part order; then the top
        let mut acc: Vec<Vec<f64>> = vec![vec![0.0; self.held_rows[PARTS] * nc]; PARTS];
        let jobs: Vec<_> = parts.iter_mut().zip(acc.iter_mut()).enumerate().collect();
        run_parts(par, jobs, |(p, (rows, acc))| {
            let mut tmp = Vec::new();
            for &s in &self.parts[p] {
                ctx.forward(s, rows, acc, &mut tmp);
            }
        });
        for a in &acc {
            // the block holds the updates with their sign
            for (y, v) in top.iter_mut().zip(a) {
                *y += v;
            }
        }
        let mut tmp = Vec::new();
        for &s in &self.top {
            ctx.forward(s, top, &mut [], &mut tmp);
        }
        // the rows from zero_from on
        for s in 0..self.owner.len() {
            if end[s] <= zero_from {
                continue;
            }
            let (r0, r1) = (begin[s].max(zero_from), end[s]);
            let l0 = self.local[r0] as usize;
            let held = match self.owner[s] {
                Owner::Part(p, _) => &mut *parts[p],
                Owner::Top => &mut *top,
            };
            held[l0 * nc..(l0 + r1 - r0) * nc].fill(0.0);
        }
        // backward: the top, then the parts reading its rows
        for &s in self.top.iter().rev() {
            ctx.backward(s, top, &[], &mut tmp);
        }
        let jobs: Vec<_> = parts.iter_mut().enumerate().collect();
        run_parts(par, jobs, |(p, rows)| {
            let mut tmp = Vec::new();
            for &s in self.parts[p].iter().rev() {
                ctx.backward(s, rows, top, &mut tmp);
            }
        });
    }

    /// Where the row `row` of supernode `s` is held in a [`SolveRows`]' data:
    /// its owner's block (the parts' in order, then the top's), its place there.
    fn held_at(&self, s: usize, row: usize, nc: usize) -> usize {
        let base: usize = self.held_rows[..self.owner[s].block()].iter().sum();
        (base + self.local[row] as usize) * nc
    }

    /// A [`SolveRows`]' data cut into the parts' blocks and the top's.
    fn blocks<'a>(&self, data: &'a mut [f64], nc: usize) -> (Vec<&'a mut [f64]>, &'a mut [f64]) {
        let mut parts = Vec::with_capacity(PARTS);
        let mut rest = data;
        for &r in &self.held_rows[..PARTS] {
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut(r * nc);
            parts.push(mine);
            rest = tail;
        }
        (parts, rest)
    }

    /// The numeric factorisation `P A P^T = L L^T` into `values` (faer's
    /// supernodal layout of `sym`, zeroed by the caller) of the symmetric `a`
    /// stored in full (both triangles: its columns are read in place, no
    /// permuted copy; `perm` = (`fwd`, `inv`), `fwd[new] = old`): the
    /// supernodes of each part in parallel, sequential dense kernels, then
    /// the top with `par` in its (larger) dense blocks.
    /// Left-looking as faer's own: a supernode gathers the updates of the
    /// supernodes below it, then factors its diagonal block and solves its
    /// off-diagonal one. `false` on a non-positive pivot (`a` not positive
    /// definite; module docs).
    pub fn factorize(
        &self,
        sym: &SymbolicSupernodalCholesky<usize>,
        (fwd, inv): (&[usize], &[usize]),
        a: SparseColMatRef<'_, usize, f64>,
        values: &mut [f64],
        par: Par,
    ) -> bool {
        let n = a.nrows();
        if a.ncols() != n || fwd.len() != n || inv.len() != n {
            return false;
        }
        let lower = Permuted { a, fwd, inv };
        let ok: Vec<bool> = {
            let (mut parts, _) = self.values_by_owner(sym, values);
            let mut ok = vec![true; parts.len()];
            let jobs: Vec<_> = parts.iter_mut().zip(ok.iter_mut()).enumerate().collect();
            run_parts(par, jobs, |(p, (chunks, ok))| {
                let mut ws = Workspace::new(n);
                for i in 0..chunks.len() {
                    let (done, rest) = chunks.split_at_mut(i);
                    let slot = |d: usize| match self.owner[d] {
                        Owner::Part(_, j) => j,
                        Owner::Top => unreachable!("checked by the plan"),
                    };
                    let s = self.parts[p][i];
                    if !self.factor_supernode(
                        sym,
                        &lower,
                        s,
                        rest[0],
                        done,
                        &slot,
                        &mut ws,
                        Par::Seq,
                    ) {
                        *ok = false;
                        return;
                    }
                }
            });
            ok
        };
        if ok.contains(&false) {
            return false;
        }
        let cpv = sym.col_ptr_for_val();
        let mut slices: Vec<&mut [f64]> = Vec::with_capacity(self.owner.len());
        let mut rest = values;
        for s in 0..self.owner.len() {
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut(cpv[s + 1] - cpv[s]);
            slices.push(mine);
            rest = tail;
        }
        let mut ws = Workspace::new(n);
        for &s in &self.top {
            let (done, rest) = slices.split_at_mut(s);
            if !self.factor_supernode(sym, &lower, s, rest[0], done, &|d| d, &mut ws, par) {
                return false;
            }
        }
        true
    }

    /// Supernode `s` of [`SolvePlan::factorize`] into `ls`, its updaters read
    /// from `done` (at `slot(d)`).
    #[allow(clippy::too_many_arguments)]
    fn factor_supernode(
        &self,
        sym: &SymbolicSupernodalCholesky<usize>,
        lower: &Permuted,
        s: usize,
        ls: &mut [f64],
        done: &[&mut [f64]],
        slot: &dyn Fn(usize) -> usize,
        ws: &mut Workspace,
        par: Par,
    ) -> bool {
        let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
        let (s0, s1) = (begin[s], end[s]);
        let sc = s1 - s0;
        let pattern = sym.supernode(s).pattern();
        let sr = sc + pattern.len();
        let g2l = &mut ws.global_to_local;
        for (i, &r) in pattern.iter().enumerate() {
            g2l[r] = sc + i;
        }
        let local = |r: usize| if r < s1 { r - s0 } else { g2l[r] };
        for j in s0..s1 {
            lower.lower_column(j, |i, v| ls[local(i) + (j - s0) * sr] += v);
        }
        for &d in &self.updaters[self.updaters_ptr[s]..self.updaters_ptr[s + 1]] {
            let d = d as usize;
            let dp = sym.supernode(d).pattern();
            let dc = end[d] - begin[d];
            let ld = MatRef::from_column_major_slice(&*done[slot(d)], dc + dp.len(), dc);
            let p0 = dp.partition_point(|&r| r < s0);
            let p1 = dp.partition_point(|&r| r < s1);
            let (m, q) = (dp.len() - p0, p1 - p0);
            let below = ld.subrows(dc + p0, m);
            let (r0, c0) = (local(dp[p0]), dp[p0] - s0);
            if (0..m).all(|ii| local(dp[p0 + ii]) == r0 + ii) {
                // the rows land in one run of the block (and so the columns):
                // the product straight into it (its upper triangle's part is
                // cleared after the diagonal block's factorisation)
                let dst = MatMut::from_column_major_slice_mut(ls, sr, sc);
                let dst = dst.submatrix_mut(r0, c0, m, q);
                let mid = below.subrows(0, q).transpose();
                matmul(
                    dst,
                    Accum::Add,
                    below,
                    mid,
                    -1.0,
                    dense_par(m * q * dc, par),
                );
                continue;
            }
            // scattered rows: the product by blocks of columns (the scratch
            // stays small beside a large top supernode's update), each from
            // its diagonal down
            for jb in (0..q).step_by(UPDATE_BLOCK_COLS) {
                let (qb, rows) = (UPDATE_BLOCK_COLS.min(q - jb), m - jb);
                ws.tmp.clear();
                ws.tmp.resize(rows * qb, 0.0);
                let t = MatMut::from_column_major_slice_mut(&mut ws.tmp, rows, qb);
                matmul(
                    t,
                    Accum::Replace,
                    below.subrows(jb, rows),
                    below.subrows(jb, qb).transpose(),
                    1.0,
                    dense_par(rows * qb * dc, par),
                );
                for jl in 0..qb {
                    let c = (dp[p0 + jb + jl] - s0) * sr;
                    for il in jl..rows {
                        ls[local(dp[p0 + jb + il]) + c] -= ws.tmp[il + jl * rows];
                    }
                }
            }
        }
        let par = dense_par(sc * sc * sr, par);
        let lsm = MatMut::from_column_major_slice_mut(ls, sr, sc);
        let (mut top, bot) = lsm.split_at_row_mut(sc);
        // the dense Cholesky's scratch is a few columns: out of memory for it
        // reads as a failed factorisation
        let scratch = cholesky_in_place_scratch::<f64>(sc, par, Default::default());
        let Ok(mut mem) = MemBuffer::try_new(scratch) else {
            return false;
        };
        let factored = cholesky_in_place(
            top.as_mut(),
            Default::default(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        );
        if factored.is_err() {
            return false;
        }
        for j in 1..sc {
            top.as_mut().col_mut(j).subrows_mut(0, j).fill(0.0);
        }
        solve_lower_triangular_in_place(top.as_ref(), bot.transpose_mut(), par);
        true
    }

    /// `values` cut into the supernodes' blocks, handed to their parts (in
    /// the parts' order) and to the top.
    #[allow(clippy::type_complexity)]
    fn values_by_owner<'a>(
        &self,
        sym: &SymbolicSupernodalCholesky<usize>,
        values: &'a mut [f64],
    ) -> (Vec<Vec<&'a mut [f64]>>, Vec<&'a mut [f64]>) {
        let cpv = sym.col_ptr_for_val();
        self.cut(values, |s| cpv[s + 1] - cpv[s])
    }

    /// `x` cut into consecutive pieces of `len(s)` per supernode `s`, handed
    /// to the supernode's part (in the part's order) or to the top.
    #[allow(clippy::type_complexity)]
    fn cut<'a>(
        &self,
        x: &'a mut [f64],
        len: impl Fn(usize) -> usize,
    ) -> (Vec<Vec<&'a mut [f64]>>, Vec<&'a mut [f64]>) {
        let mut parts: Vec<Vec<&mut [f64]>> = self
            .parts
            .iter()
            .map(|p| Vec::with_capacity(p.len()))
            .collect();
        let mut top = Vec::with_capacity(self.top.len());
        let mut rest = x;
        for s in 0..self.owner.len() {
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut(len(s));
            rest = tail;
            match self.owner[s] {
                Owner::Part(p, _) => parts[p].push(mine),
                Owner::Top => top.push(mine),
            }
        }
        (parts, top)
    }
}

/// The columns of `P A P^T` of a symmetric `A` stored in full (both
/// triangles, as the products read it, [`super::product`]), read in place:
/// column `j` is `A`'s column `fwd[j]` with its rows renumbered by `inv`.
#[derive(Clone, Copy)]
struct Permuted<'a> {
    a: SparseColMatRef<'a, usize, f64>,
    fwd: &'a [usize],
    inv: &'a [usize],
}

impl Permuted<'_> {
    /// `f(i, a_ij)` for the entries of column `j` of `P A P^T` on or below the
    /// diagonal (`i >= j`).
    fn lower_column(&self, j: usize, mut f: impl FnMut(usize, f64)) {
        let c = self.fwd[j];
        let (rows, val) = (self.a.symbolic().row_idx(), self.a.val());
        for p in self.a.symbolic().col_range(c) {
            let i = self.inv[rows[p]];
            if i >= j {
                f(i, val[p]);
            }
        }
    }
}

/// Each (permuted) row's place among its owner's rows ([`SolvePlan::local`]),
/// the rows each part and the top hold ([`SolvePlan::held_rows`]), and per
/// supernode how many of its pattern's rows its owner holds; `None` when a
/// part's pattern does not list its own rows before the top's.
#[allow(clippy::type_complexity)]
fn row_places(
    sym: &SymbolicSupernodalCholesky<usize>,
    owner: &[Owner],
    supernode_of_row: &[u32],
) -> Option<(Vec<u32>, Vec<usize>, Vec<u32>)> {
    let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
    let (ns, n) = (owner.len(), supernode_of_row.len());
    // each row's place among its owner's rows; a part's pattern rows in
    // the part first, then the top's
    if n >= u32::MAX as usize {
        return None;
    }
    let mut local = vec![0u32; n];
    let mut held_rows = vec![0usize; PARTS + 1];
    for s in 0..ns {
        let held = &mut held_rows[owner[s].block()];
        let first = *held;
        *held += end[s] - begin[s];
        for (k, l) in local[begin[s]..end[s]].iter_mut().enumerate() {
            *l = (first + k) as u32;
        }
    }
    let mut own = vec![0u32; ns];
    for s in 0..ns {
        let pattern = sym.supernode(s).pattern();
        let in_top = |r: usize| matches!(owner[supernode_of_row[r] as usize], Owner::Top);
        own[s] = match owner[s] {
            Owner::Top => pattern.len() as u32,
            Owner::Part(..) => {
                let k = pattern.iter().take_while(|&&r| !in_top(r)).count();
                if !pattern[k..].iter().all(|&r| in_top(r)) {
                    return None;
                }
                k as u32
            }
        };
    }
    Some((local, held_rows, own))
}

/// The supernodes that update each supernode ([`SolvePlan::updaters`]) and
/// their pointers; `None` for an unsorted pattern, or an update across
/// parts or from the top into a part.
fn updaters(
    sym: &SymbolicSupernodalCholesky<usize>,
    owner: &[Owner],
    supernode_of_row: &[u32],
) -> Option<(Vec<u32>, Vec<usize>)> {
    let ns = owner.len();
    // the updaters (patterns ascending, so a supernode's rows are a run);
    // a part's supernode is updated from its own part only
    let mut updaters_ptr = vec![0usize; ns + 1];
    for d in 0..ns {
        let pattern = sym.supernode(d).pattern();
        if !pattern.is_sorted_by(|a, b| a < b) {
            return None;
        }
        let mut last = usize::MAX;
        for &r in pattern {
            let q = supernode_of_row[r] as usize;
            if q != last {
                let same_part = match (owner[d], owner[q]) {
                    (Owner::Part(a, _), Owner::Part(b, _)) => a == b,
                    (Owner::Top, Owner::Part(..)) => false,
                    (_, Owner::Top) => true,
                };
                if q <= d || !same_part {
                    return None;
                }
                updaters_ptr[q + 1] += 1;
                last = q;
            }
        }
    }
    for s in 0..ns {
        updaters_ptr[s + 1] += updaters_ptr[s];
    }
    let mut updaters = vec![0u32; updaters_ptr[ns]];
    let mut next = updaters_ptr.clone();
    for d in 0..ns {
        let mut last = usize::MAX;
        for &r in sym.supernode(d).pattern() {
            let q = supernode_of_row[r] as usize;
            if q != last {
                updaters[next[q]] = d as u32;
                next[q] += 1;
                last = q;
            }
        }
    }
    Some((updaters, updaters_ptr))
}

/// Threads for a dense kernel of about `work` multiply-adds: `par` from
/// [`PAR_MIN_WORK`] on, sequential below (faer's threads cost more than
/// they save on the small blocks that most supernodes are).
fn dense_par(work: usize, par: Par) -> Par {
    if work >= PAR_MIN_WORK {
        par
    } else {
        Par::Seq
    }
}

/// Columns of an updater's product formed at once where its rows scatter
/// ([`SolvePlan::factorize`]): the scratch of a product with `m` rows is at
/// most `8 m` times this many bytes.
const UPDATE_BLOCK_COLS: usize = 128;

/// See [`dense_par`].
const PAR_MIN_WORK: usize = 1 << 21;

/// Per-thread scratch of the factorisation.
struct Workspace {
    /// Row of the current supernode's block of each of its pattern's rows.
    global_to_local: Vec<usize>,
    /// An updater's product.
    tmp: Vec<f64>,
}

impl Workspace {
    fn new(n: usize) -> Self {
        Self {
            global_to_local: vec![0; n],
            tmp: Vec::new(),
        }
    }
}

/// Runs `f` on each job, in parallel when `par` has threads.
fn run_parts<J: Send>(par: Par, jobs: Vec<J>, f: impl Fn(J) + Sync + Send) {
    if par.degree() > 1 {
        use rayon::prelude::*;
        jobs.into_par_iter().for_each(f);
    } else {
        jobs.into_iter().for_each(f);
    }
}

/// Right-hand sides regrouped for the solves ([`SolvePlan::gather`]): each
/// part's rows in the part's order, then the top's, `nc` values per row, in
/// one block (as large as the right-hand sides: one allocation per solve).
#[derive(Debug)]
pub struct SolveRows {
    data: Vec<f64>,
    nc: usize,
}

/// What the supernode kernels read.
#[derive(Clone, Copy)]
struct Ctx<'a> {
    llt: SupernodalLltRef<'a, usize, f64>,
    plan: &'a SolvePlan,
    nc: usize,
}

impl<'a> Ctx<'a> {
    /// Supernode `s`'s diagonal and off-diagonal blocks of `L`, its pattern,
    /// how many of the pattern's rows its owner holds, and where its own rows
    /// start among them.
    #[allow(clippy::type_complexity)]
    fn block(&self, s: usize) -> (MatRef<'a, f64>, MatRef<'a, f64>, &'a [usize], usize, usize) {
        let sn = self.llt.supernode(s);
        let l = sn.val();
        let (l_top, l_bot) = l.split_at_row(l.ncols());
        let first = self.plan.local[self.llt.symbolic().supernode_begin()[s]] as usize;
        (l_top, l_bot, sn.pattern(), self.plan.own[s] as usize, first)
    }

    /// Supernode `s` of `L z = b` in its owner's `rows`: the diagonal block
    /// solved, the off-diagonal block's update subtracted from the owner's
    /// rows or added to `acc`, the part's block of the top rows.
    fn forward(&self, s: usize, rows: &mut [f64], acc: &mut [f64], tmp: &mut Vec<f64>) {
        let nc = self.nc;
        let (l_top, l_bot, pattern, own, first) = self.block(s);
        let size = l_top.ncols();
        tmp.clear();
        tmp.resize(pattern.len() * nc, 0.0);
        let (head, later) = rows.split_at_mut((first + size) * nc);
        {
            let mut xs = MatMut::from_row_major_slice_mut(&mut head[first * nc..], size, nc);
            solve_lower_triangular_in_place(l_top, xs.as_mut(), Par::Seq);
            let t = MatMut::from_column_major_slice_mut(tmp, pattern.len(), nc);
            matmul(t, Accum::Replace, l_bot, xs.as_ref(), 1.0, Par::Seq);
        }
        let base = first + size;
        let np = pattern.len();
        for (k, &r) in pattern.iter().enumerate() {
            let (dst, at) = if k < own {
                (&mut *later, (self.plan.local[r] as usize - base) * nc)
            } else {
                (&mut *acc, self.plan.local[r] as usize * nc)
            };
            for (j, y) in dst[at..at + nc].iter_mut().enumerate() {
                *y -= tmp[k + j * np];
            }
        }
    }

    /// Supernode `s` of `L^T y = z` in its owner's `rows`: the off-diagonal
    /// block's rows gathered from the owner's rows or the `top` rows, then
    /// the diagonal block solved.
    fn backward(&self, s: usize, rows: &mut [f64], top: &[f64], tmp: &mut Vec<f64>) {
        let nc = self.nc;
        let (l_top, l_bot, pattern, own, first) = self.block(s);
        let size = l_top.ncols();
        let (head, later) = rows.split_at_mut((first + size) * nc);
        let base = first + size;
        tmp.clear();
        tmp.reserve(pattern.len() * nc);
        let (mine, theirs) = pattern.split_at(own);
        for &r in mine {
            let at = (self.plan.local[r] as usize - base) * nc;
            tmp.extend_from_slice(&later[at..at + nc]);
        }
        for &r in theirs {
            let at = self.plan.local[r] as usize * nc;
            tmp.extend_from_slice(&top[at..at + nc]);
        }
        let mut xs = MatMut::from_row_major_slice_mut(&mut head[first * nc..], size, nc);
        let t = MatRef::from_row_major_slice(tmp, pattern.len(), nc);
        matmul(
            xs.as_mut(),
            Accum::Add,
            l_bot.transpose(),
            t,
            -1.0,
            Par::Seq,
        );
        solve_upper_triangular_in_place(l_top.transpose(), xs.as_mut(), Par::Seq);
    }
}

#[cfg(test)]
mod tests {
    use crate::structure::sparse::{
        for_each_entry, sparse_from_triplets, sparse_to_dense, Ordering, SparseCholesky,
        SparseMatrix, SymbolicFactor, Xorshift,
    };
    use faer::Par;

    /// The 7-point Laplacian of an `n^3` grid plus a random diagonal shift: SPD,
    /// with a deep elimination tree.
    fn grid(n: usize, rng: &mut Xorshift) -> SparseMatrix {
        let id = |i: usize, j: usize, k: usize| (i * n + j) * n + k;
        let mut t = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    let a = id(i, j, k);
                    t.push((a, a, 7.0 + 0.5 * rng.next()));
                    for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (p, q, r) = (i + di, j + dj, k + dk);
                        if p < n && q < n && r < n {
                            let b = id(p, q, r);
                            t.push((a, b, -1.0));
                            t.push((b, a, -1.0));
                        }
                    }
                }
            }
        }
        sparse_from_triplets(n * n * n, &t).unwrap()
    }

    #[test]
    fn planned_solves_equal_the_dense_solution() {
        let mut rng = Xorshift(0x5eed_0001);
        for &(n, ordering) in &[
            (4, Ordering::Amd),
            (12, Ordering::Amd),
            (14, Ordering::NestedDissection),
        ] {
            let a = grid(n, &mut rng);
            let dense = sparse_to_dense(&a);
            let sym = SymbolicFactor::with_ordering(&a, ordering).unwrap();
            assert!(sym.plan.is_some() || n < 10, "n {n}: no plan");
            let seq = SparseCholesky::with_symbolic(&sym, &a, Par::Seq).unwrap();
            let par = SparseCholesky::with_symbolic(&sym, &a, Par::rayon(2)).unwrap();
            for nc in [1, 3, 10] {
                let b = rng.block(a.nrows(), nc);
                let mut x = b.clone();
                seq.solve_in_place(&mut x);
                let r = (&dense * &x - &b).amax();
                assert!(r <= 1e-12, "n {n} nc {nc}: residual {r}");
                // the rounding does not depend on the threads
                let mut y = b.clone();
                par.solve_in_place(&mut y);
                assert_eq!(x, y);
            }
        }
    }

    /// `a` with its entries mapped by `f(row, col, value)`.
    fn mapped(a: &SparseMatrix, f: impl Fn(usize, usize, f64) -> f64) -> SparseMatrix {
        let mut t = Vec::new();
        for_each_entry(a, |r, c, v| t.push((r, c, f(r, c, v))));
        sparse_from_triplets(a.nrows(), &t).unwrap()
    }

    #[test]
    fn planned_factor_equals_faers() {
        let mut rng = Xorshift(0x5eed_0003);
        for &(n, ordering) in &[(12, Ordering::Amd), (14, Ordering::NestedDissection)] {
            let a = grid(n, &mut rng);
            let sym = SymbolicFactor::with_ordering(&a, ordering).unwrap();
            assert!(sym.plan.is_some(), "n {n}: no plan");
            let ours = SparseCholesky::with_symbolic(&sym, &a, Par::rayon(2)).unwrap();
            let faer = SparseCholesky::faer_values(&sym, a.as_ref(), Par::Seq).unwrap();
            let faer = SparseCholesky::lower_values(&sym, &faer);
            let scale = faer.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = ours
                .values()
                .iter()
                .zip(&faer)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(err <= 1e-13 * scale, "n {n}: |L - L_faer| {err} of {scale}");
            // the subtrees' grouping is fixed: the same rounding on one thread
            let seq = SparseCholesky::with_symbolic(&sym, &a, Par::Seq).unwrap();
            assert_eq!(seq.values(), ours.values());
        }
    }

    #[test]
    fn planned_factor_refuses_an_indefinite_or_nan_matrix() {
        let mut rng = Xorshift(0x5eed_0004);
        let a = grid(12, &mut rng);
        let sym = SymbolicFactor::with_ordering(&a, Ordering::NestedDissection).unwrap();
        assert!(sym.plan.is_some());
        // the grid's eigenvalues lie in about [1, 13.5]: shifted by -5, indefinite
        let indefinite = mapped(&a, |r, c, v| if r == c { v - 5.0 } else { v });
        let nan = mapped(
            &a,
            |r, c, v| if (r, c) == (900, 900) { f64::NAN } else { v },
        );
        for par in [Par::Seq, Par::rayon(2)] {
            assert!(SparseCholesky::with_symbolic(&sym, &indefinite, par).is_none());
            assert!(SparseCholesky::with_symbolic(&sym, &nan, par).is_none());
            assert!(SparseCholesky::with_symbolic(&sym, &a, par).is_some());
        }
    }

    #[test]
    fn planned_leading_solve_is_the_solve_without_the_last_dofs() {
        let mut rng = Xorshift(0x5eed_0002);
        let a = grid(12, &mut rng);
        let n = a.nrows();
        let last = [5, 700, 1200];
        let sym = SymbolicFactor::with_last(&a, Ordering::NestedDissection, &last).unwrap();
        assert!(sym.plan.is_some());
        let f = SparseCholesky::with_symbolic(&sym, &a, Par::rayon(2)).unwrap();
        let keep: Vec<usize> = (0..n).filter(|i| !last.contains(i)).collect();
        let dense = sparse_to_dense(&a).select_rows(&keep).select_columns(&keep);
        let b = rng.block(n, 4);
        let mut x = b.clone();
        f.solve_leading_in_place(&mut x);
        for &d in &last {
            assert!(x.row(d).iter().all(|v| *v == 0.0));
        }
        let r = (&dense * x.select_rows(&keep) - b.select_rows(&keep)).amax();
        assert!(r <= 1e-12, "residual {r}");
    }
}
