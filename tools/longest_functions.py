#!/usr/bin/env python3
"""Print the longest Rust functions of the workspace outside tests (lines from `fn` to its closing brace).

Usage: python3 tools/longest_functions.py [N] [--max LINES]
  N       how many to print (default 10)
  --max   exit 1 when a function other than the pickle VM is longer than LINES (default: no check)

Skipped: target/, fuzz/, tests/ directories, benches, examples, and `#[cfg(test)]` modules. Braces inside
strings, chars and comments are ignored by a small lexer, so the counts hold for ordinary Rust.
"""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SKIP_DIRS = {"target", "fuzz", "tests", "benches", "examples", ".git", "node_modules"}
# The pickle VM is one dispatch over opcodes; splitting it would scatter the protocol.
EXEMPT = {("io/src/pickle.rs", "run")}
FN = re.compile(r"^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?(extern\s+\"[^\"]*\"\s+)?fn\s+(\w+)")


def code_only(text):
    """The text with string, char and comment contents blanked (newlines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "r" and re.match(r'r#*"', text[i:i + 10]) and (i == 0 or not text[i - 1].isalnum()):
            hashes = re.match(r"r(#*)\"", text[i:]).group(1)
            end = '"' + hashes
            j = text.find(end, i + 2 + len(hashes))
            j = n if j < 0 else j + len(end)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append(re.sub(r"[^\n]", " ", text[i:j + 1]))
            i = j + 1
        elif c == "'" and re.match(r"'(\\.|[^\\'])'|'\\u\{[0-9a-fA-F]+\}'|'\\x[0-9a-fA-F]{2}'", text[i:i + 12]):
            m = re.match(r"'(\\.|[^\\'])'|'\\u\{[0-9a-fA-F]+\}'|'\\x[0-9a-fA-F]{2}'", text[i:i + 12])
            out.append(" " * len(m.group(0)))
            i += len(m.group(0))
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(path, rel):
    lines = code_only(open(path, encoding="utf-8").read()).split("\n")
    skip_until = -1
    depth_at = []
    depth = 0
    found = []
    pending_test = False
    i = 0
    while i < len(lines):
        line = lines[i]
        if "#[cfg(test)]" in line:
            pending_test = True
        m = FN.match(line)
        if i > skip_until and pending_test and re.match(r"^\s*(pub\s+)?mod\s+\w+", line):
            skip_until = block_end(lines, i)
            pending_test = False
        elif i > skip_until and m:
            end = block_end(lines, i)
            if end is not None:
                found.append((end - i + 1, rel, m.group(7), i + 1))
        if line.strip() and not line.strip().startswith("#"):
            pending_test = pending_test and "#[cfg(test)]" in line
        i += 1
    return found


def block_end(lines, start):
    """The line of the brace closing the first block opened at or after `start` (None for `fn f();`)."""
    depth, opened = 0, False
    for j in range(start, len(lines)):
        for ch in lines[j]:
            if ch == "{":
                depth += 1
                opened = True
            elif ch == "}":
                depth -= 1
                if opened and depth == 0:
                    return j
            elif ch == ";" and not opened and depth == 0:
                return None
    return None


def main():
    args = sys.argv[1:]
    limit = None
    if "--max" in args:
        k = args.index("--max")
        limit = int(args[k + 1])
        del args[k:k + 2]
    count = int(args[0]) if args else 10
    found = []
    for dirpath, dirnames, filenames in os.walk(ROOT):
        dirnames[:] = sorted(d for d in dirnames if d not in SKIP_DIRS)
        for f in sorted(filenames):
            if f.endswith(".rs"):
                path = os.path.join(dirpath, f)
                rel = os.path.relpath(path, ROOT)
                found.extend(functions(path, rel))
    found.sort(key=lambda x: (-x[0], x[1], x[3]))
    for n, rel, name, line in found[:count]:
        print(f"{n:5d}  {rel}:{line}  {name}")
    if limit is not None:
        over = [f for f in found if f[0] > limit and (f[1], f[2]) not in EXEMPT]
        if over:
            print(f"{len(over)} function(s) longer than {limit} lines", file=sys.stderr)
            sys.exit(1)


if __name__ == "__main__":
    main()
