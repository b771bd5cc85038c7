#!/usr/bin/env python3
"""self_contained.py — the repository explains itself (docs/design.md §9).

Checks, over every file git tracks (or, outside a git checkout, every file
under the root but build folders):

1. No file points outside the repository for its meaning: no citation of a
   design file that is not in it ("DESIGN.md", "STYLE.md"), no tracker
   number ("issue 37", "(issues 35 and 37)", "Issue 15:", an "issue" at the
   end of a comment line whose number begins the next), no path into a
   sibling folder of the checkout ("../shared/").  Say what is meant, or
   point at a page of docs/.
2. Every relative link in a Markdown file ([text](path), ![img](path))
   names a file or folder that exists, and every docs/NAME.md named in any
   file exists.
3. The README is the front door: at most 400 lines, it shows the two
   commands (./scripts/demo.sh and ./scripts/test.sh: .ci/run calls the
   second), and every page in docs/ is reachable from it by links.

This file itself is the one exception to check 1: it has to spell the
patterns.  Usage: self_contained.py [ROOT]; prints each offence as FILE:LINE
and exits 1."""
import os
import re
import subprocess
import sys

root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                       os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
me = os.path.relpath(os.path.abspath(__file__), root) if len(sys.argv) <= 1 else "tests/self_contained.py"

README_MAX_LINES = 400
TWO_COMMANDS = ("./scripts/demo.sh", "./scripts/test.sh")

OUTSIDE = [
    (re.compile(r"(?<![\w/.-])(DESIGN|STYLE)\.md"), "cites a design file that is not in the repository"),
    # "issue 37", "issues 35 and 37", "Issue #3", and "issue" / "(issue" at a
    # line's end with the number after the next line's comment marker
    (re.compile(r"(?i)\bissues?\b[ \t]*(\r?\n[ \t]*(\*|#|//|--|;)?)?[ \t]*#?\d"), "cites a tracker's issue number"),
    (re.compile(r"\.\./shared/"), "points at a folder outside the repository"),
]
MD_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
DOCS_NAMED = re.compile(r"(?<![\w/.-])docs/([\w.-]+\.md)\b")
FENCE = re.compile(r"^(```|~~~)")


def tracked_files():
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], capture_output=True, check=True).stdout
        files = [f for f in out.decode("utf-8", "surrogateescape").split("\0") if f]
        if files:
            return [f for f in files if os.path.isfile(os.path.join(root, f))]
    except (OSError, subprocess.CalledProcessError):
        pass
    files = []
    for d, dirs, names in os.walk(root):
        dirs[:] = sorted(x for x in dirs if not (x.startswith(".") or x.startswith("build") or x == "out"))
        files += [os.path.relpath(os.path.join(d, n), root) for n in sorted(names)]
    return files


def read_text(path):
    """The file as text, or None for a binary one (a NUL in its first 8 KiB)."""
    with open(os.path.join(root, path), "rb") as f:
        data = f.read()
    if b"\0" in data[:8192]:
        return None
    return data.decode("utf-8", "replace")


def line_of(text, pos):
    return text.count("\n", 0, pos) + 1


def markdown_links(text):
    """(line, target) of every link outside fenced code blocks."""
    fenced = False
    for n, line in enumerate(text.split("\n"), 1):
        if FENCE.match(line.lstrip()):
            fenced = not fenced
            continue
        if fenced:
            continue
        for m in MD_LINK.finditer(line):
            yield n, m.group(1)


def local_target(md_path, target):
    """The repository path a relative link names, or None for a URL or an anchor."""
    if re.match(r"^[a-zA-Z][\w+.-]*:", target) or target.startswith("#"):
        return None
    target = target.split("#", 1)[0]
    if not target:
        return None
    if target.startswith("/"):
        return os.path.normpath(target.lstrip("/"))
    return os.path.normpath(os.path.join(os.path.dirname(md_path), target))


def main():
    offences = []
    files = tracked_files()
    texts = {}
    for f in files:
        t = read_text(f)
        if t is not None:
            texts[f] = t

    # 1. nothing points outside the repository
    for f, t in texts.items():
        if f == me:
            continue
        for pattern, why in OUTSIDE:
            for m in pattern.finditer(t):
                offences.append("%s:%d: %s: %r" % (f, line_of(t, m.start()), why, m.group(0).strip()))

    # 2. links and named docs pages resolve
    links = {}
    for f, t in texts.items():
        if f.endswith(".md"):
            links[f] = []
            for n, target in markdown_links(t):
                p = local_target(f, target)
                if p is None:
                    continue
                if p.startswith("..") or not os.path.exists(os.path.join(root, p)):
                    offences.append("%s:%d: link to %s, which is not in the repository" % (f, n, target))
                else:
                    links[f].append(p)
        if f == me:
            continue
        for m in DOCS_NAMED.finditer(t):
            if not os.path.isfile(os.path.join(root, "docs", m.group(1))):
                offences.append("%s:%d: names docs/%s, which does not exist" % (f, line_of(t, m.start()), m.group(1)))

    # 3. the README as the front door
    readme = texts.get("README.md")
    if readme is None:
        offences.append("README.md: missing")
    else:
        n = readme.count("\n") + (0 if readme.endswith("\n") else 1)
        if n > README_MAX_LINES:
            offences.append("README.md: %d lines, more than the front door's %d (move a topic to docs/)" % (n, README_MAX_LINES))
        for cmd in TWO_COMMANDS:
            if not re.search(r"^%s$" % re.escape(cmd), readme, re.M):
                offences.append("README.md: does not show the command %s on a line of its own" % cmd)
        seen, todo = {"README.md"}, ["README.md"]
        while todo:
            for p in links.get(todo.pop(), []):
                if p not in seen:
                    seen.add(p)
                    todo.append(p)
        for f in sorted(texts):
            if f.startswith("docs/") and f.endswith(".md") and f not in seen:
                offences.append("%s: not reachable by links from README.md" % f)

    for o in offences:
        print(o)
    if offences:
        print("self_contained: %d offence(s)" % len(offences), file=sys.stderr)
        return 1
    print("self_contained: %d files, %d Markdown pages: nothing points outside the repository, every link resolves"
          % (len(texts), len(links)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
