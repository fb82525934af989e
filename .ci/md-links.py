#!/usr/bin/env python3
"""Every relative link of the repository's Markdown files (tracked or new, not ignored) points at a
file that exists, and a #fragment into a Markdown file at one of its headings (GitHub's slugs).

    python3 .ci/md-links.py [ROOT]

Links inside fenced code blocks and absolute URLs are not checked. Exits 1 and lists the broken
links.
"""

import os
import re
import subprocess
import sys


def markdown_files(root: str) -> list[str]:
    out = []
    for extra in ([], ["--others", "--exclude-standard"]):
        r = subprocess.run(["git", "-C", root, "ls-files", *extra, "*.md"], capture_output=True, text=True, check=True)
        out += r.stdout.split()
    return out


def anchors(path: str) -> set[str]:
    out = set()
    with open(path, encoding="utf-8") as f:
        for line in f:
            m = re.match(r"#+\s+(.*)", line)
            if m:
                out.add(re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-"))
    return out


def main() -> int:
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    bad = []
    for f in markdown_files(root):
        with open(os.path.join(root, f), encoding="utf-8") as fh:
            text = re.sub(r"```.*?```", "", fh.read(), flags=re.S)
        for m in re.finditer(r"\]\(([^)\s]+)\)", text):
            url = m.group(1)
            if re.match(r"[a-z][a-z0-9+.-]*:", url):
                continue
            path, _, frag = url.partition("#")
            target = os.path.normpath(os.path.join(root, os.path.dirname(f), path)) if path else os.path.join(root, f)
            if not os.path.exists(target):
                bad.append(f"{f}: {url}: no such file")
            elif frag and target.endswith(".md") and frag not in anchors(target):
                bad.append(f"{f}: {url}: no such heading")
    for b in bad:
        print(b, file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
