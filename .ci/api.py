#!/usr/bin/env python3
"""The library's public items, as rustdoc lists them, against docs/api.md.

Reads target/doc/linpose/all.html (made by `cargo doc --no-deps -p linpose`, the library's
default features: no renderer, no bench internals) and writes or checks the item list at the end
of docs/api.md, under its "## Every public item" heading.

    python3 .ci/api.py            # check: exit 1 when docs/api.md's list differs from rustdoc's
    python3 .ci/api.py --write    # rewrite the list
"""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ALL = ROOT / "target/doc/linpose/all.html"
DOC = ROOT / "docs/api.md"
HEAD = "## Every public item"
KINDS = {"struct": "struct", "enum": "enum", "trait": "trait", "fn": "fn", "type": "type", "static": "static", "constant": "const", "macro": "macro", "mod": "mod"}


def items() -> list[str]:
    text = ALL.read_text()
    out = []
    for href, name in re.findall(r'<li><a href="([^"]+)">([^<]+)</a></li>', text):
        kind = Path(href).name.split(".")[0]
        out.append(f"{KINDS.get(kind, kind)} {name}")
    return out


def listing(found: list[str]) -> str:
    by_module: dict[str, list[str]] = {}
    for it in found:
        kind, path = it.split(" ", 1)
        module = path.rsplit("::", 1)[0] if "::" in path else "(root)"
        by_module.setdefault(module, []).append(f"`{path}` ({kind})")
    lines = [HEAD, "", f"{len(found)} items, as `cargo doc --no-deps -p linpose` lists them (`python3 .ci/api.py --write` remakes this list; CI checks it).", ""]
    for module in sorted(by_module):
        lines.append(f"- **{module}**: " + ", ".join(sorted(by_module[module])))
    return "\n".join(lines) + "\n"


def main() -> int:
    if not ALL.exists():
        print(f"{ALL} is missing: run `cargo doc --no-deps -p linpose` first")
        return 1
    doc = DOC.read_text()
    if HEAD not in doc:
        print(f"{DOC} has no '{HEAD}' section")
        return 1
    head = doc[: doc.index(HEAD)]
    want = head + listing(items())
    if "--write" in sys.argv:
        DOC.write_text(want)
        print(f"{DOC.relative_to(ROOT)}: {len(items())} public items listed")
        return 0
    if doc != want:
        print(f"{DOC.relative_to(ROOT)}: the list of public items differs from rustdoc's ({len(items())} items); run `python3 .ci/api.py --write` and review")
        return 1
    print(f"docs/api.md lists the {len(items())} public items")
    return 0


if __name__ == "__main__":
    sys.exit(main())
