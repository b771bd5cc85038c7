#!/usr/bin/python3
"""One of the held-in family's block media (docs/multigrid.md, "Any medium";
src/studies/block_medium.c's family_blocks for N + 1 cells, the same draws)
as a scan: a u8 volume of random 8^3 blocks moved by 3 cells, whose sigma_s' takes LEVELS
levels spread evenly in the logarithm over 1 .. 1e6 (blocks9: sigma_a over
1e-3 .. 1 with its level, the rest 1e-3), written raw to OUT, and the
transfer function that gives each level its medium to TRANSFER.  Level L is
density 10 (L + 1).  The volume has N + 1 voxels a side, so that
`-voxelize voxel=1` makes N^3 cells: the grid covers the span between the
first and last voxel centres, so each cell's centre is a corner of eight
voxels and takes their trilinear mean.  Inside a block that is the block's
density; on the cells whose centres lie on a block face it is a blend (the
transfer function's interpolation), as in any scan sampled between voxels:
the faces are one cell thick and moved by 3.5 cells from the hierarchy's,
not exactly the family's.  As scripts/block-medium.py's, voxel (0, 0, 0) is
0, the scan's background.

    scripts/family-medium.py N LEVELS OUT TRANSFER
    ohm -read file=OUT dims=N+1,N+1,N+1 type=u8 spacing=1 -voxelize voxel=1 threshold=5 \
        -material transfer=TRANSFER ..."""
import sys

import numpy as np

if len(sys.argv) != 5:
    sys.exit(__doc__)
n, levels = int(sys.argv[1]), int(sys.argv[2])
if n < 2 or not 2 <= levels <= 24:
    sys.exit("family-medium.py: N must be at least 2 and LEVELS 2 .. 24")
BLOCK, SHIFT, MASK = 8, 3, (1 << 64) - 1
nb = (n + 1 + SHIFT + BLOCK - 1) // BLOCK
seed = 12
level = np.empty(nb**3, dtype=np.int64)
for q in range(nb**3):  # ohm_lcg (block_medium.h): Knuth's MMIX constants
    seed = (seed * 6364136223846793005 + 1442695040888963407) & MASK
    u = (seed >> 11) / 9007199254740992.0
    level[q] = levels - 1 - int(u * levels)
# cell i lies in block (i + SHIFT) // BLOCK along each axis; q = bi + nb (bj + nb bk)
b = (np.arange(n + 1) + SHIFT) // BLOCK
lv = level.reshape(nb, nb, nb)[b[:, None, None], b[None, :, None], b[None, None, :]]  # [k, j, i]
v = (10 * (lv + 1)).astype(np.uint8)
v[0, 0, 0] = 0
v.tofile(sys.argv[3])  # x fastest: the array is [z, y, x]
with open(sys.argv[4], "w") as f:
    f.write("ohm-transfer 1\n")
    for L in range(levels):
        t = L / (levels - 1)
        sa = 1e-3 * 10 ** (3 * t) if levels == 9 else 1e-3
        f.write("%d %.9g %.9g\n" % (10 * (L + 1), sa, 10 ** (6 * t)))
