#!/usr/bin/env python3
"""Writes frame_M.mtx and frame_K.mtx beside this script: a plane steel portal
frame (two clamped columns of height 0.4 m, a beam of 0.6 m, flat bar
30 x 10 mm bent about its weak axis), Euler-Bernoulli frame elements (axial +
bending, consistent mass), 4 elements per member, 13 nodes with (ux, uy, rz),
the two base nodes clamped: 33 DOFs. Plain Python, no dependencies.

DOF numbering (0-based rows of the matrices): the free nodes 1..11 in order,
3 DOFs each (ux, uy, rz), so node n has ux at row 3 (n - 1). Node 2 is the left
column at mid-height, node 4 the top-left corner, node 8 the top-right corner.
"""
import os

E, RHO = 2.1e11, 7800.0
B, T = 0.03, 0.01  # width, thickness (in-plane height) [m]
A, I = B * T, B * T**3 / 12.0
H, L, NE = 0.4, 0.6, 4

nodes = [(0.0, H * i / NE) for i in range(NE + 1)]
nodes += [(L * i / NE, H) for i in range(1, NE + 1)]
nodes += [(L, H - H * i / NE) for i in range(1, NE + 1)]
elements = [(i, i + 1) for i in range(len(nodes) - 1)]
clamped = {0, len(nodes) - 1}
ndof = 3 * len(nodes)


def element(xy1, xy2):
    dx, dy = xy2[0] - xy1[0], xy2[1] - xy1[1]
    le = (dx * dx + dy * dy) ** 0.5
    c, s = dx / le, dy / le
    a, b = E * A / le, E * I / le**3
    k = [[a, 0, 0, -a, 0, 0],
         [0, 12 * b, 6 * b * le, 0, -12 * b, 6 * b * le],
         [0, 6 * b * le, 4 * b * le**2, 0, -6 * b * le, 2 * b * le**2],
         [-a, 0, 0, a, 0, 0],
         [0, -12 * b, -6 * b * le, 0, 12 * b, -6 * b * le],
         [0, 6 * b * le, 2 * b * le**2, 0, -6 * b * le, 4 * b * le**2]]
    m0 = RHO * A * le
    r = m0 / 420.0
    m = [[m0 / 3, 0, 0, m0 / 6, 0, 0],
         [0, 156 * r, 22 * le * r, 0, 54 * r, -13 * le * r],
         [0, 22 * le * r, 4 * le**2 * r, 0, 13 * le * r, -3 * le**2 * r],
         [m0 / 6, 0, 0, m0 / 3, 0, 0],
         [0, 54 * r, 13 * le * r, 0, 156 * r, -22 * le * r],
         [0, -13 * le * r, -3 * le**2 * r, 0, -22 * le * r, 4 * le**2 * r]]
    t = [[0.0] * 6 for _ in range(6)]
    for o in (0, 3):
        t[o][o], t[o][o + 1], t[o + 1][o], t[o + 1][o + 1], t[o + 2][o + 2] = c, s, -s, c, 1.0

    def rot(x):  # t^T x t
        xt = [[sum(x[i][k2] * t[k2][j] for k2 in range(6)) for j in range(6)] for i in range(6)]
        return [[sum(t[k2][i] * xt[k2][j] for k2 in range(6)) for j in range(6)] for i in range(6)]

    return rot(k), rot(m)


K = [[0.0] * ndof for _ in range(ndof)]
M = [[0.0] * ndof for _ in range(ndof)]
for n1, n2 in elements:
    ke, me = element(nodes[n1], nodes[n2])
    dofs = [3 * n1 + j for j in range(3)] + [3 * n2 + j for j in range(3)]
    for i, gi in enumerate(dofs):
        for j, gj in enumerate(dofs):
            K[gi][gj] += ke[i][j]
            M[gi][gj] += me[i][j]
free = [d for d in range(ndof) if d // 3 not in clamped]


def write(path, a):
    n = len(free)
    entries = [(r, c, a[free[r]][free[c]]) for c in range(n) for r in range(c, n)
               if abs(a[free[r]][free[c]]) > 1e-14 * max(abs(a[free[c]][free[c]]), 1e-300)]
    with open(path, "w") as f:
        f.write("%%MatrixMarket matrix coordinate real symmetric\n")
        f.write("% plane portal frame, see make_frame.py\n")
        f.write(f"{n} {n} {len(entries)}\n")
        for r, c, v in entries:
            f.write(f"{r + 1} {c + 1} {v:.17g}\n")


here = os.path.dirname(os.path.abspath(__file__))
write(os.path.join(here, "frame_M.mtx"), M)
write(os.path.join(here, "frame_K.mtx"), K)
