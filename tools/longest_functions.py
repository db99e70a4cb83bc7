#!/usr/bin/env python3
"""The longest functions in the tree (issue 38's proof): a definition is a line at column 0 that ends a
signature with '{' (this project's style: namespaces are not indented), and it ends at the next line that is a
lone '}' at column 0. Prints the N longest with their line counts (signature to closing brace).
Usage: tools/longest_functions.py [N] [ROOT]   (default 5, the repository's app/ and tracer/)"""
import os, re, sys

n = int(sys.argv[1]) if len(sys.argv) > 1 else 5
root = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
skip = re.compile(r"^(namespace|struct|class|enum|union|extern|template\s*<[^>]*>\s*(struct|class))\b")
found = []
for top in ("app", "tracer"):
    for d, _, files in os.walk(os.path.join(root, top)):
        for f in files:
            if not f.endswith((".cpp", ".h")):
                continue
            path = os.path.join(d, f)
            lines = open(path, encoding="utf-8", errors="replace").read().split("\n")
            i = 0
            while i < len(lines):
                line = lines[i]
                if re.match(r"^[A-Za-z_\[]", line) and not skip.match(line) and not line.startswith("template") \
                        and not re.match(r"^[A-Z_0-9]+\s*(//.*)?$", line):
                    # the signature: from this column-0 line to the first line ending in '{' (or a ';': none)
                    k = i
                    while k < len(lines) and k < i + 10 and not lines[k].rstrip().endswith(("{", ";")):
                        k += 1
                    sig = " ".join(lines[i:k + 1])
                    if k < len(lines) and lines[k].rstrip().endswith("{") and "(" in sig and "=" not in sig.split("(")[0]:
                        j = k + 1
                        while j < len(lines) and lines[j].rstrip() != "}":
                            j += 1
                        name = re.search(r"([A-Za-z_][A-Za-z_0-9:~]*)\s*\(", sig)
                        found.append((j - i + 1, os.path.relpath(path, root), i + 1, name.group(1) if name else sig[:40]))
                        i = j
                i += 1
found.sort(reverse=True)
for length, path, line, name in found[:n]:
    print(f"{length:5d}  {name}  ({path}:{line})")
