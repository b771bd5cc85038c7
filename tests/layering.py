#!/usr/bin/env python3
"""layering.py — the source tree's architecture, checked: src/ is in folders
by stage, and a file may include headers of its own stage or of an earlier
one, never of a later one ("nothing below reaching up").  Includes of ohm's
own headers name the folder ("grid/voxelize.h"); the C++ shims in wrappers/
(ohm_vdb.h, ohm_oiio.h, ohm_gdcm.h), the generated ohm_version.h and the public
vocabulary include/ohm/common.h (status codes) are below every stage; a
header the build generates from a stage's own file (solvers/mg_device_cl.h,
physics/mc_device_cl.h: the kernels' source as a string) belongs to that stage.  The
public API (include/ohm.h, implemented in src/api/) is above them all but the
command line, and the command line is its client: src/cli/ includes ohm.h
(and ohm/cli.h, the command line's own entry points) and
nothing else of ohm's.

Around src/:
- wrappers/: a shim includes the headers of its own folder ("ohm_oiio.h"),
  ohm's error vocabulary (base/ohm_error.h, ohm/common.h) and its library's
  headers, nothing else of ohm's: no stage, no other wrapper.
- tests/ (with tests/fuzz/): any stage's header, the wrappers' C headers,
  ohm_version.h, the public ohm.h and ohm/common.h, and the helpers beside
  the test ("check.h").
- examples/: clients of the installed library: they include the public
  headers as <ohm.h> (or <ohm/common.h>) and nothing else of ohm's.

ohm's own headers are included in quotes everywhere but examples/: an
angle-bracket include that names one (<base/log.h>, <ohm_vdb.h>, <ohm.h>) is
an offence in src/, wrappers/ and tests/.

No circles between files, either: a file and its header are one node (a .c
and the .h of its name), and an include is an edge from the including
file's node to the header's; a node that reaches itself through others (A
includes B.h, and B.c or B.h includes A.h; or a longer ring) is a cycle in
the design, whatever the stages allow.  Each cycle is printed as its nodes
in order.

Prints each offending include as FILE:LINE and each cycle, and exits 1."""
import os
import re
import sys

STAGES = ["base", "device", "input", "grid", "physics", "solvers", "outputs", "studies", "steps", "api", "cli"]
WRAPPER_API = {"ohm_vdb.h", "ohm_oiio.h", "ohm_gdcm.h"}
BELOW_ALL = WRAPPER_API | {"ohm_version.h", "ohm/common.h"}
ERROR_VOCABULARY = {"base/ohm_error.h", "ohm/common.h"}  # what a wrapper may include of ohm's
PUBLIC_API = {"ohm.h", "ohm/cli.h"}  # implemented in src/api/: above every stage but the command line
# headers the build generates from a stage's own file (cmake/embed_text.cmake): of that stage
GENERATED = {"solvers/mg_device_cl.h": "solvers/mg_device.cl", "physics/mc_device_cl.h": "physics/mc_device.cl"}
SOURCES = (".c", ".h", ".cpp", ".hpp", ".cc")

root = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
src = os.path.join(root, "src")
quoted = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
angled = re.compile(r'^\s*#\s*include\s+<([^>]+)>')


def files_under(top, name):
    """Relative paths (root-based) of the sources in top/name, with subfolders."""
    out = []
    for d, dirs, files in os.walk(os.path.join(top, name)):
        dirs.sort()
        out += [os.path.relpath(os.path.join(d, f), top) for f in sorted(files) if f.endswith(SOURCES)]
    return out


PUBLIC = set(files_under(os.path.join(root, "include"), "."))  # ohm.h, ohm/common.h
WRAPPER_HEADERS = {os.path.basename(f) for f in files_under(root, "wrappers") if f.endswith((".h", ".hpp"))}


def in_src(header):
    """A stage's header: a file under src/, or one the build generates from a stage's file."""
    if header in GENERATED:
        return os.path.isfile(os.path.join(src, GENERATED[header]))
    return "/" in header and header.split("/")[0] in STAGES and os.path.isfile(os.path.join(src, header))


def own_header(header):
    """Does this include name one of ohm's own headers (not a system or library one)?"""
    return in_src(header) or header in PUBLIC or header in WRAPPER_HEADERS or header == "ohm_version.h" or \
        header in GENERATED


def includes(rel):
    """(line number, header, in angle brackets?) of each include in a root-relative file."""
    for lineno, line in enumerate(open(os.path.join(root, rel), encoding="utf-8"), 1):
        m = quoted.match(line)
        if m:
            yield lineno, m.group(1), False
            continue
        m = angled.match(line)
        if m:
            yield lineno, m.group(1), True


def beside(rel, header):
    return os.path.isfile(os.path.join(root, os.path.dirname(rel), header))


bad = []
checked = 0


def check(rel, rule):
    """Each include of the root-relative file rel through rule(header, angled):
    None when the header is not ohm's (not counted), "" when the include is
    fine, else what is wrong with it."""
    global checked
    for lineno, header, is_angled in includes(rel):
        verdict = rule(header, is_angled)
        if verdict is None:
            continue
        checked += 1
        if verdict:
            shown = "<%s>" % header if is_angled else '"%s"' % header
            bad.append("%s:%d: #include %s: %s" % (rel, lineno, shown, verdict))


def in_angle_brackets(header, rel, helpers_too=False):
    """The verdict on an angle-bracket include outside examples/: an offence
    when it names one of ohm's own headers, not counted otherwise."""
    if own_header(header) or (helpers_too and beside(rel, header)):
        return 'one of ohm\'s own headers in angle brackets: write "%s"' % header
    return None


# ---- src/: the stages ----------------------------------------------------------
def stage_rule(stage):
    level = STAGES.index(stage)

    def rule(header, is_angled):
        if is_angled:
            return in_angle_brackets(header, None)
        if stage == "cli" and header not in PUBLIC_API and not header.startswith("cli/"):
            return "the command line uses the public API (ohm.h, ohm/cli.h) only"
        if header in BELOW_ALL:
            return ""
        if header in PUBLIC_API:
            to = "api"
        elif "/" in header:
            to = header.split("/")[0]
        else:
            return "names no stage folder"
        generated = header in GENERATED and os.path.exists(os.path.join(src, GENERATED[header]))
        if to not in STAGES or not os.path.exists(os.path.join(src, header)) and header not in PUBLIC_API and \
                not generated:
            return "no such header under src/"
        if STAGES.index(to) > level:
            return "stage %s reaches up to %s" % (stage, to)
        return ""
    return rule


folders = sorted(d for d in os.listdir(src) if os.path.isdir(os.path.join(src, d)))
for d in folders:
    if d not in STAGES:
        bad.append("src/%s: a folder that is no stage of %s" % (d, ", ".join(STAGES)))
for f in sorted(os.listdir(src)):
    if os.path.isfile(os.path.join(src, f)):
        bad.append("src/%s: a file outside the stage folders" % f)
for stage in folders:
    if stage not in STAGES:
        continue
    for name in sorted(os.listdir(os.path.join(src, stage))):
        if name.endswith((".c", ".h")):
            check("src/%s/%s" % (stage, name), stage_rule(stage))


# ---- wrappers/: each shim on its own ----------------------------------------------
def wrapper_rule(rel):
    def rule(header, is_angled):
        if is_angled:
            return in_angle_brackets(header, rel)
        if header in ERROR_VOCABULARY or ("/" not in header and beside(rel, header)):
            return ""
        return "a wrapper includes its own folder's headers and ohm's error vocabulary (%s) only" % ", ".join(
            sorted(ERROR_VOCABULARY))
    return rule


for rel in files_under(root, "wrappers"):
    check(rel, wrapper_rule(rel))


# ---- tests/: any stage, the wrappers' C headers, the public API ---------------------
def test_rule(rel):
    def rule(header, is_angled):
        if is_angled:
            return in_angle_brackets(header, rel, helpers_too=True)
        if in_src(header) or header in BELOW_ALL or header in PUBLIC or beside(rel, header):
            return ""
        if header in WRAPPER_HEADERS:
            return "a wrapper's own header; tests use its C header (%s)" % ", ".join(sorted(WRAPPER_API))
        return "no such header under src/ or include/, nor beside the test"
    return rule


for rel in files_under(root, "tests"):
    check(rel, test_rule(rel))


# ---- examples/: clients of the installed header -------------------------------------
def example_rule(rel):
    def rule(header, is_angled):
        if is_angled:
            if not own_header(header):
                return None  # the C library's, or another library's
            return "" if header in PUBLIC else "examples use the public API only (<ohm.h>)"
        if header in PUBLIC:
            return "an example includes the installed header: write <%s>" % header
        if not own_header(header) and beside(rel, header):
            return ""  # the example's own helper
        return "examples use the public API only (<ohm.h>)"
    return rule


for rel in files_under(root, "examples"):
    check(rel, example_rule(rel))

# ---- src/: no cycles between files ---------------------------------------------------
def node(rel):
    """A file's node: its path in src/ without the extension (x.c and x.h are one)."""
    return os.path.splitext(rel)[0]


def include_graph():
    """node -> the nodes its files include (quoted includes of src/ headers)."""
    graph = {}
    for stage in folders:
        if stage not in STAGES:
            continue
        for name in sorted(os.listdir(os.path.join(src, stage))):
            if not name.endswith((".c", ".h")):
                continue
            rel = "%s/%s" % (stage, name)
            edges = graph.setdefault(node(rel), set())
            for _, header, is_angled in includes(os.path.join("src", rel)):
                if not is_angled and in_src(header) and node(header) != node(rel):
                    edges.add(node(header))
    return graph


def cycles(graph):
    """Each strongly connected component of more than one node (Tarjan), as
    one ring through all of it found by walking its edges."""
    index, low, stack, on, comps = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    rings = []
    for comp in comps:
        members = set(comp)
        start = comp[0]
        # the shortest way back to start inside the component (breadth first)
        prev, frontier, found = {start: None}, [start], None
        while frontier and found is None:
            nxt = []
            for v in frontier:
                for w in sorted(graph.get(v, ())):
                    if w not in members:
                        continue
                    if w == start:
                        found = v
                        break
                    if w not in prev:
                        prev[w] = v
                        nxt.append(w)
                if found is not None:
                    break
            frontier = nxt
        ring, v = [], found
        while v is not None:
            ring.append(v)
            v = prev[v]
        ring.reverse()
        rings.append((ring, comp))
    return rings


sys.setrecursionlimit(10000)
for ring, comp in cycles(include_graph()):
    text = " -> ".join(ring + [ring[0]])
    rest = sorted(set(comp) - set(ring))
    bad.append("src/: a cycle of includes: %s%s" % (text, " (and through %s)" % ", ".join(rest) if rest else ""))

for b in bad:
    print(b)
print("layering: %d includes in %d stages, wrappers/, tests/ and examples/ checked, %d problem(s)"
      % (checked, len(folders), len(bad)))
sys.exit(1 if bad or checked == 0 else 0)
