#!/usr/bin/python3
"""peak_rss.py OUT cmd...: run cmd, write the peak resident memory (kB) of
it and everything it waited for into OUT, exit with cmd's exit code (a
signal's death as 128 + its number, as a shell reports it)."""
import resource, subprocess, sys

code = subprocess.call(sys.argv[2:])
with open(sys.argv[1], "w") as f:
    f.write("%d\n" % resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
sys.exit(128 - code if code < 0 else code)
