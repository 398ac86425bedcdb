#!/usr/bin/env python3
"""A shipped scene in the form a Mitsuba 3 user has it: its integrator
replaced by Mitsuba's volpath (max_depth 64, rr_depth 5, as the references
were made; tools/reference.py's substitution), so that spm derives every
setting, and its relative file names made absolute so that the file may live
anywhere.

    tools/mitsuba_form.py scenes/NAME.xml OUT.xml"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reference import substitute_integrator  # noqa: E402


def mitsuba_form(path):
    text = substitute_integrator(open(path).read(), 64, 5)
    folder = os.path.dirname(os.path.abspath(path))
    return re.sub(r'(<string name="filename" value=")([^"/][^"]*)"',
                  lambda m: m.group(1) + os.path.join(folder, m.group(2)) + '"', text)


def main():
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    with open(sys.argv[2], "w") as f:
        f.write(mitsuba_form(sys.argv[1]))


if __name__ == "__main__":
    main()
