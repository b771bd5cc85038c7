#!/usr/bin/python3
"""The scale studies' block medium (docs/scale.md): an N^3 u8 volume of 8^3
blocks, each density 10 or 20 at random (p = 1/2, a fixed seed), written raw
to OUT.  Both phases percolate (site percolation on the cubic lattice needs
p > 0.31), so light must find its way through a maze of conductances 1e6
apart (with blocks.transfer: sigma_s' 1 or 1e6 /mm).  (A checkerboard of
such blocks is no test: its diffusive blocks touch only at edges, isolated
pieces that CG solves in 25 iterations, docs/scale.md.)  One corner voxel is
0: a scan's background is its lowest value (docs/scans.md), and with 0 there the
grid's margin is outside and the object is the N^3 blocks (without it, a
4-cell shell of the diffusive phase: (N+8)^3 cells).

    scripts/block-medium.py N OUT [TRANSFER]

TRANSFER, if given, is where the medium's transfer function is written."""
import sys

import numpy as np

if len(sys.argv) not in (3, 4):
    sys.exit(__doc__)
n = int(sys.argv[1])
rng = np.random.default_rng(12)
b = rng.random(((n + 7) // 8,) * 3) < 0.5
i = np.arange(n) // 8
v = np.where(b[i[:, None, None], i[None, :, None], i[None, None, :]], 20, 10).astype(np.uint8)
v[0, 0, 0] = 0
v.tofile(sys.argv[2])
if len(sys.argv) == 4:
    with open(sys.argv[3], "w") as f:
        f.write("ohm-transfer 1\n10 0.001 1\n20 0.001 1e6\n")
