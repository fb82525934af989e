#!/usr/bin/env python3
"""Links in a crate's rustdoc HTML that lead nowhere.

rustdoc warns about intra-doc links it cannot resolve, not about those it resolves to an item
whose page it does not generate: with `--no-deps` such a link is printed as its source text
(`[`mesh`]`) or written as an unusable href (`href="mod@format"`), silently. This walks
`target/doc/CRATE` and reports, per page, relative hrefs whose file does not exist, hrefs
that are still a disambiguated path (`mod@…`), and link text left in brackets.

Usage: doc-links.py DOC_DIR CRATE   (exit 1 when something is broken)
"""
import os
import re
import sys
from urllib.parse import unquote, urldefrag

root, crate = sys.argv[1], sys.argv[2]
if not os.path.isfile(os.path.join(root, crate, "index.html")):
    sys.exit(f"no rustdoc output at {os.path.join(root, crate)}")
broken = {}
for folder, _, files in os.walk(os.path.join(root, crate)):
    for name in files:
        if not name.endswith(".html"):
            continue
        page = os.path.join(folder, name)
        with open(page, encoding="utf-8", errors="replace") as f:
            html = f.read()
        for href in re.findall(r'href="([^"]+)"', html):
            # External, in-page, and rustdoc's own script templates.
            if href.startswith(("http:", "https:", "#", "javascript:", "mailto:")) or "${" in href:
                continue
            if re.match(r"^[a-z]+@", href):
                broken.setdefault(page, set()).add(href)
                continue
            target = unquote(urldefrag(href)[0])
            if target and not os.path.exists(os.path.normpath(os.path.join(folder, target))):
                broken.setdefault(page, set()).add(href)
        for text in re.findall(r"\[<code>[A-Za-z_:]+</code>\]", html):
            broken.setdefault(page, set()).add("unlinked " + text)
for page, links in sorted(broken.items()):
    print(f"{os.path.relpath(page, root)}: {', '.join(sorted(links))}")
count = sum(len(v) for v in broken.values())
print(f"{crate}: {count} broken links in {len(broken)} pages", file=sys.stderr)
sys.exit(1 if count else 0)
