#!/usr/bin/env python3
"""layering.py — the source tree's architecture, checked: src/ is in folders
by stage, and a file may include headers of its own stage or of an earlier
one, never of a later one ("nothing below reaching up").  Includes of ohm's
own headers name the folder ("grid/voxelize.h"); the C++ shims in wrappers/
(ohm_vdb.h, ohm_oiio.h, ohm_gdcm.h), the generated ohm_version.h and the public
vocabulary include/ohm/common.h (status codes) are below every stage.  The
public API (include/ohm.h, implemented in src/api/) is above them all but the
command line, and the command line is its client: src/cli/ includes ohm.h and
nothing else of ohm's.
Prints each offending include as FILE:LINE and exits 1."""
import os
import re
import sys

STAGES = ["base", "input", "grid", "physics", "solvers", "outputs", "studies", "steps", "api", "cli"]
BELOW_ALL = {"ohm_vdb.h", "ohm_oiio.h", "ohm_gdcm.h", "ohm_version.h", "ohm/common.h"}

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
src = os.path.join(root, "src")
include = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
bad = []
checked = 0
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
    level = STAGES.index(stage)
    for name in sorted(os.listdir(os.path.join(src, stage))):
        if not name.endswith((".c", ".h")):
            continue
        path = os.path.join(src, stage, name)
        for lineno, line in enumerate(open(path, encoding="utf-8"), 1):
            m = include.match(line)
            if not m:
                continue
            checked += 1
            header = m.group(1)
            where = "src/%s/%s:%d" % (stage, name, lineno)
            if stage == "cli" and header != "ohm.h" and not header.startswith("cli/"):
                bad.append('%s: #include "%s": the command line uses the public API (ohm.h) only' % (where, header))
                continue
            if header in BELOW_ALL:
                continue
            if header == "ohm.h":
                to = "api"
            elif "/" in header:
                to = header.split("/")[0]
            else:
                bad.append('%s: #include "%s" names no stage folder' % (where, header))
                continue
            if to not in STAGES or not os.path.exists(os.path.join(src, header)) and header != "ohm.h":
                bad.append('%s: #include "%s": no such header under src/' % (where, header))
            elif STAGES.index(to) > level:
                bad.append('%s: #include "%s": stage %s reaches up to %s' % (where, header, stage, to))
for b in bad:
    print(b)
print("layering: %d includes in %d stages checked, %d problem(s)" % (checked, len(folders), len(bad)))
sys.exit(1 if bad or checked == 0 else 0)
