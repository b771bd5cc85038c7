"""The memory a Solve will take and the solver Auto takes, asked of the
library before anything is built (ohm_scene_estimate, include/ohm.h: the
model is the library's, docs/blender.md compares it with measured peaks), so
that a panel value that would not fit is refused at once (with the figure it
needs and the largest Cells that fits) instead of exhausting Blender's
memory.  No bpy here: scripts/addon-memory.py checks the same predictions
against measured peaks outside Blender."""

try:  # the package bundled into the add-on's zip (lib/libohm.so.1 beside it)
    from . import ohm as ohmlib
except ImportError:  # running from a source tree with ohm on sys.path
    import ohm as ohmlib

# Live relight solves again each time a light moves: Auto weighs the
# factor's setup against this many solves of each channel, a few minutes of
# moving lights at the rates measured (docs/blender.md).
LIVE_SOLVES = 200


def ask(ctx, verts, tris, dim, solver, channels, budget_bytes, solves=LIVE_SOLVES):
    """The library's estimate (a dict: interior_cells, bytes_direct ...
    bytes_auto, bytes_allowed, margin, largest_dim, largest_dim_mg, solver,
    reason) for the mesh (mm) at `dim` cells across."""
    with ohmlib.Scene(ctx) as sc:
        sc.set_mesh(verts, tris, name="estimate")
        return sc.estimate(dim=dim, solver=solver, channels=channels, solves=solves,
                           max_memory=max(budget_bytes, 1.0) / 2 ** 20)


def guarded_bytes(est, solver):
    """What the guard sets against the memory allowed: the prediction with
    the model's margin for its error."""
    return est["margin"] * est["bytes_" + solver]


def gib(nbytes):
    if nbytes >= 1e12:
        return "%.1f TB" % (nbytes / 1e12)
    return "%.1f GB" % (nbytes / 1e9) if nbytes >= 1e9 else "%.0f MB" % (nbytes / 1e6)


def check(est, dim, solver, budget, share):
    """None when a Solve at dim with `solver` fits budget (the estimate
    asked with that solver), else the one-line refusal: what it needs, what
    is allowed, the largest Cells that fits (and with Multigrid, when that
    is more)."""
    need = guarded_bytes(est, solver)
    if need <= budget:
        return None
    best = est["largest_dim"]
    text = "Cells %d with solver %s needs up to %s, more than the %s Memory allows (%s)" % (
        dim, solver, gib(need), gib(budget), share)
    text += "; the largest Cells that fits is %d" % best if best >= 4 else "; no Cells setting fits"
    if solver in ("direct", "auto", "amg") and est["largest_dim_mg"] > best:
        text += " (%d with Solver: Multigrid)" % est["largest_dim_mg"]
    return text
