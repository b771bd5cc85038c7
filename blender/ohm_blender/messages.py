"""What ohm says, in the artist's words.

The library speaks its command line and physics ("argument 1: -voxelize
error=0.001 needs dim=2032 ... max_dim=587", "albedo 0.678 < 0.8").  Each of
its failures and warnings becomes a Note here: a headline that names the
panel's settings ("Cells", "Memory", "Scale"), the object and the light and
says what to do next; a details line with the figures in physics terms but
no command-line syntax, for the panel; and the library's own text, for the
console.  The library gives a coarse kind (ohm.Error.code: usage, memory,
invalid input ...) and no finer one, so the table below is keyed on the
stable words of each message (the figures around them vary).  No bpy here:
Subject holds what the messages need from Blender, read by the operators."""
import re

try:  # the package bundled into the add-on's zip, as session.py finds it
    from . import ohm as ohmlib
except ImportError:  # running from a source tree with ohm on sys.path
    import ohm as ohmlib

# The command line's words in a message: "-voxelize", "argument 1", "type=".
# No headline or details line may hold them (tests/blender_reports.py).
CLI_SYNTAX = re.compile(r"(?<![\w-])-(read|voxelize|material|light|solve|write|place|render)\b|argument \d|\b\w+=")
CHANNELS = {"R": "red", "G": "green", "B": "blue"}


class Note:
    """One message: level ('ERROR', 'WARNING' or 'INFO', Blender's report
    types), the headline, the details line ('' when the headline says it
    all) and the library's text it came from ('' for the add-on's own)."""
    __slots__ = ("level", "text", "details", "raw", "kind")

    def __init__(self, level, text, details="", raw="", kind=""):
        self.level, self.text, self.details, self.raw, self.kind = level, text, details, raw, kind

    def __repr__(self):
        return "Note(%s, %r)" % (self.level, self.text)


class Subject:
    """What the messages name: the object, its lights (name, ohm type) in
    the order the add-on gave them, and the panel's settings."""

    def __init__(self, name, lights=(), dim=0, error=0.0, grid="DIM", memory=50, material="the material",
                 scale_mm=1.0, scale_auto=True, size_units=0.0):
        self.name, self.lights, self.dim, self.error, self.grid = name, list(lights), dim, error, grid
        self.memory, self.material, self.scale_mm, self.scale_auto = memory, material, scale_mm, scale_auto
        self.size_units = size_units  # the object's largest dimension, scene units

    def size_text(self, scale_mm=None):
        """The object's size as solved at scale_mm (mm per unit), e.g. '27 cm'."""
        return length_text(self.size_units * (self.scale_mm if scale_mm is None else scale_mm))

    def scale_text(self):
        return "Scale %s (1 unit = %s)" % ("Auto" if self.scale_auto else "%.4g" % self.scale_mm,
                                          length_text(self.scale_mm))


def length_text(mm):
    if mm >= 1000.0:
        return "%.3g m" % (mm / 1000.0)
    return "%.3g cm" % (mm / 10.0) if mm >= 10.0 else "%.3g mm" % mm


def plain(raw):
    """The library's text without its command-line syntax: no 'argument N:',
    no '-voxelize', 'dim=64' as 'dim 64', no hint that names an option."""
    t = re.sub(r"\bargument \d+: ", "", raw)
    t = re.sub(r"\s*\((?:use|put)\b[^()]*=[^()]*\)", "", t)   # "(use a smaller voxel, or -voxelize error=)"
    t = re.sub(r";\s*(?:use|put)\b[^;]*=[^;]*$", "", t)        # "; use a larger error="
    t = re.sub(r"(?<![\w-])-(read|voxelize|material|light|solve|write|place|render)\b:? ?", "", t)
    t = re.sub(r"\btype=(\w+)", r"\1", t)
    t = re.sub(r"\b(\w+)=(?=\S)", r"\1 ", t)
    return re.sub(r"\b(\w+)=", r"\1", t).strip()


def _and(words):
    words = list(words)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _figure(text):
    return float(text.rstrip(".,;"))


# ---- failures: (the message's stable words, headline) -------------------------

def _zero_extent(m, s):
    return "%s has no size: its object scale is 0 or all its vertices are at one point. Give it a size " \
           "(Object > Transform > Scale)" % s.name


def _no_faces(m, s):
    return "%s has no faces: ohm needs a solid, closed mesh for light to scatter in. Add faces, or select " \
           "another object" % s.name


def _flat(m, s):
    return "%s is flat (no thickness along %s): light needs a solid to scatter in. Give it thickness, e.g. with " \
           "a Solidify modifier" % (s.name, m.group(1).upper())


def _target_too_fine(m, s):
    return "Accuracy target: Error %s needs %s Cells across %s, but Memory %d%% fits at most %s. Raise Error " \
           "(a coarser target), raise Memory, or choose Grid: Cells across" % (
               m.group(1), m.group(2), s.name, s.memory, m.group(3))


def _too_big(m, s):
    cells = ("Cells %d" % s.dim) if s.grid == "DIM" else "this accuracy target"
    return "%s at %s needs about %s, more than the %s Memory %d%% allows. Lower Cells, or raise Memory" % (
        s.name, cells, m.group(1), m.group(2), s.memory)


def _no_light(m, s):
    names = [n for n, _ in s.lights]
    which = "the light %s" % names[0] if len(names) == 1 else "none of the lights (%s)" % ", ".join(names)
    if len(names) == 1:
        return "No light reaches %s: %s is inside it, points away from it, or lights only parts in shadow. " \
               "Move %s outside %s, or turn it towards it" % (s.name, which, names[0], s.name)
    return "No light reaches %s: %s reaches it (each is inside it, points away, or lights only parts in " \
           "shadow). Move a light outside %s, or turn it towards it" % (s.name, which, s.name)


def _not_fitting(m, s):
    return "%s is thinner than one cell at Cells %d: no cell lies inside it. Raise Cells" % (s.name, s.dim)


FAILURES = (
    (r"mesh has zero extent", _zero_extent),
    (r"\d+ vertices and \d+ triangles: a closed mesh needs", _no_faces),
    (r"the mesh is flat \(zero thickness along (\w)", _flat),
    (r"error=(\S+) needs dim=(\d+) .*more than max_dim=(\d+)", _target_too_fine),
    (r"needs about ([\d.]+ \w+)\S*, more than the ([\d.]+ \w+)", _too_big),
    (r"no light reaches", _no_light),
    (r"network: the voxel object has no interior cells", _not_fitting),
)


def failure(error, subject):
    """The Note for an exception the add-on caught (ohm.Error, OSError,
    RuntimeError)."""
    raw = str(error)
    if isinstance(error, ohmlib.Cancelled):
        return Note("WARNING", "Cancelled: %s keeps its last result" % subject.name, "", raw)
    for pattern, headline in FAILURES:
        m = re.search(pattern, raw)
        if m:
            return Note("ERROR", headline(m, subject), plain(raw), raw, "dark" if headline is _no_light else "")
    if isinstance(error, OSError):
        return Note("ERROR", "ohm could not read or write a file for %s: %s" % (subject.name, plain(raw)), "", raw)
    if isinstance(error, ohmlib.Error) and error.code == ohmlib.ERR_NOMEM:
        return Note("ERROR", "Not enough memory for %s at Cells %d: lower Cells, or raise Memory" % (
            subject.name, subject.dim), plain(raw), raw)
    text = plain(raw)
    # the add-on's own refusals (no light, Memory, a packed sky image) are worded for the panel already
    own = isinstance(error, ohmlib.UsageError) and text == raw
    return Note("ERROR", text if own else "ohm could not solve %s: %s" % (subject.name, text), "", raw)


# ---- warnings: grouped by kind (a per-channel warning is one note) -----------

def _open_mesh(ms, s):
    m = ms[-1]
    return "WARNING", "%s is not closed (%s open edges, %s non-manifold, %s flipped): ohm fills small holes " \
                      "itself; for a clean result close it (Mesh > Clean Up > Fill Holes, Normals > Recalculate " \
                      "Outside)" % (s.name, m.group(1), m.group(2), m.group(3))


def _inside_out(ms, s):
    return "WARNING", "%s's faces point inwards: ohm reads them reversed (Mesh > Normals > Recalculate Outside " \
                      "fixes the mesh)" % s.name


def _absorbing(ms, s):
    where = _and(CHANNELS[m.group(2)] for m in ms if m.group(2)) or "all colours"
    return "WARNING", "%s absorbs much of the light before it scatters (in %s): ohm's diffusion model is rough " \
                      "for it, expect errors of tens of percent" % (ms[0].group(1), where)


def _coarse(ms, s):
    """Cells coarser than light spreads: finer Cells; and where a cell is
    more than twice the farthest spread, the object is large to the light
    (opaque), so a smaller Scale too: the one that makes a cell as long as
    the farthest spread."""
    cell = _figure(ms[0].group(1))
    spread = [_figure(m.group(2)) for m in ms]
    longest, shortest = max(spread), min(spread)
    spreads = length_text(longest) if len(spread) == 1 else "%s-%s" % (length_text(shortest), length_text(longest))
    colours = _and(CHANNELS[m.group(3)] for m in ms if m.group(3))
    where = "%s%s at %s" % (s.material, " (%s)" % colours if colours else "", s.scale_text())
    cells = s.dim * cell / shortest
    more = "Raise Cells to %d" % (int(cells) + 1) if s.grid == "DIM" and cells <= 1024 else ""
    if cell <= 2 * longest:
        return "WARNING", "%s's cells (%s) are a little coarser than the %s light spreads in %s: the result is " \
                          "slightly rough. %s" % (s.name, length_text(cell), spreads, where,
                                                  more + " for full detail" if more else "Lower Error for detail")
    scale = s.scale_mm * longest / cell
    return "WARNING", "%s is %s across at %s, large to the light: it spreads only %s in %s, less than one cell " \
                      "(%s), so %s looks opaque and the result is rough. Lower Scale to about %.3g (%s across) for " \
                      "a smaller, more translucent object%s" % (
                          s.name, s.size_text(), s.scale_text(), spreads, s.material, length_text(cell), s.name,
                          scale, s.size_text(scale), ", or raise Cells to %d" % (int(cells) + 1) if more else "")


def _dark_light(ms, s):
    """Each light the library says reaches nothing, named: its warnings come
    in the order the lights were given, each with its type, so a light is
    named when it is the only one of its type, else the candidates are."""
    names = []
    for t in sorted({m.group(1) for m in ms}):
        of_type = [n for n, lt in s.lights if lt == t]
        dark = sum(1 for m in ms if m.group(1) == t)
        if len(of_type) == dark:
            names += of_type
        else:
            names.append("%d of the %s lights (%s)" % (dark, t, ", ".join(of_type)))
    names = names or ["a light"]
    return "ERROR", "%s light%s no part of %s: %s inside it, point%s away from it, or light%s only parts in " \
                    "shadow. Move %s outside %s, or turn %s towards it" % (
                        _and(names), "s" if len(names) == 1 else "", s.name,
                        "it is" if len(names) == 1 else "each is", "s" if len(names) == 1 else "",
                        "s" if len(names) == 1 else "", "it" if len(names) == 1 else "them", s.name,
                        "it" if len(names) == 1 else "them")


def _thin(ms, s):
    return "WARNING", "%s is thinner than one cell at Cells %d: no cell lies inside it. Raise Cells" % (s.name, s.dim)


def _empty_volume(ms, s):
    return "WARNING", "The Volume's values never reach the object's threshold: the object is empty. Check the " \
                      "Volume file and the Transfer function"


def _short(ms, s):
    return "WARNING", "The solver stopped short of its accuracy goal (the result is kept); for full accuracy " \
                      "choose Solver: Direct"


WARNINGS = (
    ("open", r"is not closed: (\d+) open \(boundary\) edges, (\d+) non-manifold edges, (\d+) flipped", _open_mesh),
    ("inside-out", r"is wound inside-out", _inside_out),
    ("albedo", r"material (\S+?) ?([RGB])? has albedo [\d.]+ < ", _absorbing),
    ("coarse", r"voxel (\S+) mm is larger than the diffusion length 1/sigma_tr = (\S+) mm(?: of channel ([RGB]))?",
     _coarse),
    ("dark", r"type=(\w+) reaches no part of the object", _dark_light),
    ("thin", r"no cell centre lies inside the mesh", _thin),
    ("empty", r"no cell reaches threshold", _empty_volume),
    ("short", r"stopped short of cg_tol", _short),
)


def warnings(raws, subject):
    """Notes for a run's warnings (the library's texts, in order): one per
    kind, the first of a kind deciding its place; duplicates dropped (the
    memory estimate's mesh and the solve's say the same)."""
    groups, order = {}, []
    for raw in raws:
        for kind, pattern, _ in WARNINGS:
            m = re.search(pattern, raw)
            if m:
                break
        else:
            kind, m = raw, None
        if kind not in groups:
            groups[kind] = []
            order.append(kind)
        if m is None or all(g.group(0) != m.group(0) or kind == "dark" for g, _ in groups[kind]):
            groups[kind].append((m, raw))
    notes = []
    for kind in order:
        found = groups[kind]
        if found[0][0] is None:  # a warning with no entry: its plain text
            notes.append(Note("WARNING", plain(found[0][1]), "", found[0][1], "other"))
            continue
        headline = next(h for k, _, h in WARNINGS if k == kind)
        level, text = headline([m for m, _ in found], subject)
        notes.append(Note(level, text, "; ".join(plain(raw) for _, raw in found), "\n".join(r for _, r in found),
                          kind))
    return notes
