"""The memory a Solve will take, predicted before anything is built, so that
a panel value that would not fit is refused at once (with the figure it
needs and the largest Cells that fits) instead of exhausting Blender's
memory.  No bpy here: scripts/addon-memory.py checks these predictions
against measured peaks outside Blender (docs/blender.md).

The model, fitted on 2026-12-05 to whole-process peaks of the add-on's
library path (a kept solver, three channels, a point light) on a sphere,
Spot and the Stanford bunny from 1e5 to 1.7e7 cells; every prediction was
within 13% of the measured peak:

- interior cells n = the mesh's enclosed volume / h^3, h = the longest
  extent / Cells (exact for closed meshes, within a few percent for
  nearly closed ones);
- the voxel grid: 13 B per cell of its box (the voxelizer's own estimate),
  the box padded by the band of 3 cells and one more on each side;
- solver=mg: 410 B per interior cell (each channel's stencil and hierarchy
  is kept for relighting); cg: 375 B; auto: 650 B (it chose mg for one light
  in every case measured, and holds the assembled matrix beside mg's
  stencil; it takes the factor only where the factor fits the same limit,
  which the library checks);
- solver=direct: each distinct channel's Cholesky factor, 11 B per
  nonzero, nnz(L) = 2.19 n^1.4 c^0.94, and 150 B per cell for the rest.
  n^1.4: the grid ordering's nested dissection (n^(4/3) in theory,
  1.38-1.40 measured).  c = (36 pi V^2 / S^3)^(1/3), the mesh's thickness
  3V/S over a sphere's of the same volume (1 for a sphere, 0.42 for a
  knotted tube): the fill is the separators' squares, and a thin object's
  separators are its thin cross-sections (a tube of a cells across fills
  about n a, a compact object n^(4/3)).  Fitted on 2026-12-05 to nnz(L)
  measured on eight meshes (sphere, Spot, bunny, teapot, knot, dragon,
  cow, head) at 1e5-5e5 cells: within 0.82-1.19 of each;
- amg: 74 B per cell plus 392 B per cell per channel (docs/scale-model.md);
- 95 MB for the library and its callers.

(docs/blender.md compares the predictions with measured peaks.)"""

import numpy as np

BASE_BYTES = 95 * 2 ** 20
GRID_BYTES_PER_CELL = 13.0
PAD_CELLS = 4
PER_CELL = {"mg": 410.0, "cg": 375.0, "auto": 650.0}
FACTOR_BYTES_PER_NONZERO = 11.0
FACTOR_NNZ_COEFF, FACTOR_NNZ_POWER, FACTOR_NNZ_THICKNESS_POWER = 2.19, 1.4, 0.94
DIRECT_PER_CELL = 150.0
AMG_SERIAL, AMG_PER_CHANNEL = 74.0, 392.0
MAX_DIM = 1024
# A setting is allowed when its prediction times this fits the memory
# allowed: the lowest prediction measured was 0.88 of the peak (Spot, direct,
# docs/blender.md), so a peak stays under the guard.
GUARD_MARGIN = 1.15
# Solver Auto in the add-on: the factor up to this many cells (where its
# memory fits), multigrid beyond.  Measured relight rates, Spot in marble,
# three channels, a point light moved 1 degree (scripts/relight-rate.py,
# 2026-12-05): 3.7e4 cells direct 55/s, mg 25/s; 1.25e5 direct 12.4/s, mg
# 7.4/s; 3.0e5 direct 2.9-3.1/s, mg 3.6-3.8/s; and mg's first solve is 7-25x
# quicker than the factorization at every size.
AUTO_DIRECT_MAX_CELLS = 2.5e5


def enclosed_volume(verts, tris):
    """|signed volume| of the triangle mesh (mm^3): the divergence theorem's
    sum of tetrahedra from the origin."""
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    return abs(float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0)


def surface_area(verts, tris):
    """The triangle mesh's area (mm^2)."""
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    return 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


class Shape:
    """What the prediction needs of a mesh: its extents, enclosed volume
    (mm) and thickness (compactness: 1 for a sphere, less for thin shapes)."""

    def __init__(self, verts, tris):
        self.extent = np.ptp(verts, axis=0) if len(verts) else np.zeros(3)
        self.volume = enclosed_volume(verts, tris) if len(tris) else 0.0
        area = surface_area(verts, tris) if len(tris) else 0.0
        # (36 pi V^2 / S^3)^(1/3) = (3V/S) / (3V/(4 pi))^(1/3): 3V/S is the
        # mean thickness, a sphere's the same volume's radius over 3
        self.compactness = float(np.clip((36.0 * np.pi * self.volume ** 2 / area ** 3) ** (1.0 / 3.0), 0.05, 1.0)) \
            if area > 0 else 1.0

    def cells(self, dim):
        """(interior cells, cells of the grid's box) at `dim` cells across."""
        longest = float(self.extent.max())
        if not longest > 0:
            return 0.0, 0.0
        h = longest / dim
        box = float(np.prod(np.ceil(self.extent / h - 1e-9).clip(min=1) + 2 * PAD_CELLS))
        return min(self.volume / h ** 3, box), box


def solve_bytes(shape, dim, solver, channels):
    """Predicted whole-process bytes of a Solve at `dim` with `solver`."""
    n, box = shape.cells(dim)
    grid = GRID_BYTES_PER_CELL * box
    if solver == "direct":
        nnz = FACTOR_NNZ_COEFF * n ** FACTOR_NNZ_POWER * shape.compactness ** FACTOR_NNZ_THICKNESS_POWER
        need = FACTOR_BYTES_PER_NONZERO * channels * nnz + DIRECT_PER_CELL * n
    elif solver == "amg":
        need = (AMG_SERIAL + AMG_PER_CHANNEL * channels) * n
    else:
        need = PER_CELL[solver] * n
    return BASE_BYTES + grid + need


def guarded_bytes(shape, dim, solver, channels):
    """What the guard sets against the memory allowed: the prediction with
    the margin for the model's error (GUARD_MARGIN)."""
    return GUARD_MARGIN * solve_bytes(shape, dim, solver, channels)


def largest_dim(shape, solver, channels, budget):
    """The largest Cells whose guarded prediction fits `budget` bytes (0: none)."""
    lo, hi = 0, MAX_DIM
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if guarded_bytes(shape, mid, solver, channels) <= budget:
            lo = mid
        else:
            hi = mid - 1
    return lo


def gib(nbytes):
    if nbytes >= 1e12:
        return "%.1f TB" % (nbytes / 1e12)
    return "%.1f GB" % (nbytes / 1e9) if nbytes >= 1e9 else "%.0f MB" % (nbytes / 1e6)


def check(shape, dim, solver, channels, budget, share):
    """None when a Solve at dim fits budget, else the one-line refusal:
    what it needs, what is allowed, the largest Cells that fits (and with
    Multigrid, when that is more)."""
    need = guarded_bytes(shape, dim, solver, channels)
    if need <= budget:
        return None
    best = largest_dim(shape, solver, channels, budget)
    text = "Cells %d with solver %s needs up to %s, more than the %s Memory allows (%s)" % (
        dim, solver, gib(need), gib(budget), share)
    text += "; the largest Cells that fits is %d" % best if best >= 4 else "; no Cells setting fits"
    if solver in ("direct", "auto", "amg"):
        best_mg = largest_dim(shape, "mg", channels, budget)
        if best_mg > best:
            text += " (%d with Solver: Multigrid)" % best_mg
    return text


def choose(shape, dim, channels, budget):
    """Solver Auto's choice for the add-on, where relights follow the first
    solve: (solver, why)."""
    n, _ = shape.cells(dim)
    if n > AUTO_DIRECT_MAX_CELLS:
        return "mg", "%.3g cells: multigrid relights faster beyond %.3g" % (n, AUTO_DIRECT_MAX_CELLS)
    if guarded_bytes(shape, dim, "direct", channels) > budget:
        return "mg", "the factor would not fit the memory allowed"
    return "direct", "%.3g cells: the factor relights fastest up to %.3g" % (n, AUTO_DIRECT_MAX_CELLS)
