#!/usr/bin/env python3
"""Lists the functions in src/ and shaders/ longer than a limit (default 120 lines), from the
line of `fn` to its closing brace, comments and blank lines included.

    tools/dev/long_fns.py [LIMIT]
"""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
FN = re.compile(r"^\s*(?:pub(?:\([\w:]+\))?\s+)?(?:const\s+)?(?:unsafe\s+)?(?:extern\s+\"C\"\s+)?fn\s+(\w+)")


def code_only(line):
    """The line without its // comment and string contents (braces in them do not count)."""
    line = re.sub(r'"(?:\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(?:\\.|[^'\\])'", "''", line)
    return line.split("//", 1)[0]


def functions(path):
    lines = open(path, encoding="utf-8").read().split("\n")
    i = 0
    while i < len(lines):
        m = FN.match(lines[i])
        if not m:
            i += 1
            continue
        depth, opened, nest, j = 0, False, 0, i
        declaration = False
        while j < len(lines) and not declaration:
            for ch in code_only(lines[j]):
                if ch in "([<":
                    nest += 1
                elif ch in ")]>":
                    nest -= 1
                elif ch == ";" and not opened and nest <= 0:
                    declaration = True  # no body (a trait method, an extern)
                    break
                elif ch == "{":
                    depth += 1
                    opened = True
                elif ch == "}":
                    depth -= 1
            if opened and depth == 0:
                yield m.group(1), i + 1, j - i + 1
                break
            j += 1
        i += 1


def main():
    limit = int(sys.argv[1]) if len(sys.argv) > 1 else 120
    rows = []
    for top in ("src", "shaders"):
        for root, _, names in os.walk(os.path.join(ROOT, top)):
            for n in sorted(names):
                if n.endswith((".rs", ".wgsl")):
                    p = os.path.join(root, n)
                    for name, line, length in functions(p):
                        if length > limit:
                            rows.append((length, os.path.relpath(p, ROOT), line, name))
    for length, p, line, name in sorted(rows, reverse=True):
        print(f"{length:5d}  {p}:{line}  {name}")
    print(f"{len(rows)} functions over {limit} lines")
    return 1 if rows else 0


if __name__ == "__main__":
    sys.exit(main())
