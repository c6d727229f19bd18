#!/usr/bin/env python3
"""Fails when a Rust source file grows past what one reading holds (issue 35).

Files only: the length of a function is clippy's `too_many_lines` to check, with the threshold
and the way it counts lines (code lines, not comments) stated once, in clippy.toml (issue 45).

Counts the non-blank lines (lines that are not whitespace only) of every `*.rs` file under
`src/` and `crates/*/src/`, and exits with status 1, naming each file and its count, when one
has more than LIMIT; otherwise prints one line saying all is well. Run from anywhere:
`python3 .ci/file_size.py` (standard library only).

What is not counted, and why:
- Unit tests. A file that holds only tests (`tests.rs`, `*_tests.rs`, or any file below a
  `tests/` directory inside a `src/`) is skipped, and in every other file a test module written
  in it (`#[cfg(test)]`, further attributes, then `mod name {` ... up to its closing `}` at the
  same indentation, as rustfmt lays it out) is left out of the count. Tests grow with the code
  they check and are read a test at a time; the limit is about the code a reader must hold.
  (The integration tests in the crates' `tests/` folders are outside `src/` and not looked at.)
- Generated files: a file whose first five lines mention `@generated` (the marker rustfmt and
  other tools respect). There are none today.
"""

import re
import sys
from pathlib import Path

LIMIT = 700

ROOT = Path(__file__).resolve().parent.parent

TEST_MODULE_START = re.compile(r"^(\s*)(pub(\([^)]*\))?\s+)?mod\s+\w+\s*\{\s*$")


def is_exempt(path: Path, lines: list[str]) -> bool:
    """Test-only and generated files."""
    rel = path.relative_to(ROOT).parts
    src = rel.index("src")
    if "tests" in rel[src + 1 : -1]:
        return True
    if path.name == "tests.rs" or path.name.endswith("_tests.rs"):
        return True
    return any("@generated" in line for line in lines[:5])


def counted_lines(lines: list[str]) -> int:
    """Non-blank lines outside inline `#[cfg(test)] mod ... { }` blocks."""
    count = 0
    i = 0
    while i < len(lines):
        if lines[i].strip() == "#[cfg(test)]":
            # Skip further attributes and find the module it applies to.
            j = i + 1
            while j < len(lines) and lines[j].strip().startswith("#["):
                j += 1
            m = TEST_MODULE_START.match(lines[j]) if j < len(lines) else None
            if m:
                close = m.group(1) + "}"
                k = j + 1
                while k < len(lines) and lines[k].rstrip() != close:
                    k += 1
                i = k + 1
                continue
        if lines[i].strip():
            count += 1
        i += 1
    return count


def main() -> int:
    files = sorted(
        [*ROOT.glob("src/**/*.rs"), *ROOT.glob("crates/*/src/**/*.rs")],
        key=lambda p: p.relative_to(ROOT).as_posix(),
    )
    too_long = []
    checked = 0
    for path in files:
        lines = path.read_text(encoding="utf-8").splitlines()
        if is_exempt(path, lines):
            continue
        checked += 1
        n = counted_lines(lines)
        if n > LIMIT:
            too_long.append((path.relative_to(ROOT).as_posix(), n))
    for name, n in too_long:
        print(f"{name}: {n} non-blank lines (tests not counted), more than {LIMIT}: split it")
    if too_long:
        return 1
    print(f"OK: none of {checked} Rust source files has more than {LIMIT} non-blank lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
