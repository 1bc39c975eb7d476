#!/usr/bin/env python3
"""Keeps docs/architecture.md true: the stages it names, their layers, links and GDAL/PROJ use.

    tests/architecture_check.py ROOT [--doc DOC] [--expect TEXT]...

Reads the table of DOC (default ROOT/docs/architecture.md) whose header starts
`| layer | module | target |`, and the CMake files of ROOT (CMakeLists.txt, and every
CMakeLists.txt under src/, apps/ and python/): `dsmplan_module(NAME ... PUBLIC ... PRIVATE ...)`,
`target_link_libraries(TARGET ...)`, and the targets made by `add_executable`, `add_library` and
`pybind11_add_module`. Fails, naming each offence, when

  - a module of the table has no target, or a dsmplan_module() is not in the table;
  - a stage links (PUBLIC or PRIVATE) a dsmplan_* target of its own layer or above;
  - the dsmplan_* targets a stage links differ from the table's "links to";
  - a stage whose GDAL/PROJ cell does not start with "yes" links GDAL::GDAL or PROJ::proj, or a
    source in its folder includes a GDAL, OGR, CPL or PROJ header;
  - the rows do not run from the top layer down.

With --expect, the check is inverted for a deliberately broken tree (tests/architecture/broken):
it passes only if offences are found and every TEXT is part of one of them.
"""
import argparse
import pathlib
import re
import sys

GDAL_PROJ_TARGETS = {"GDAL::GDAL", "PROJ::proj"}
GDAL_PROJ_INCLUDE = re.compile(r'^\s*#\s*include\s*[<"](gdal|ogr_|ogrsf_|cpl_|proj\.h|proj/|proj_)', re.M)


def read_table(doc):
    lines = doc.read_text(encoding="utf-8").split("\n")
    start = next((i for i, line in enumerate(lines) if re.match(r"\|\s*layer\s*\|\s*module\s*\|\s*target\s*\|", line, re.I)),
                 None)
    if start is None:
        sys.exit(f"{doc}: no table whose header starts '| layer | module | target |'")
    header = [cell.strip().lower() for cell in lines[start].strip().strip("|").split("|")]
    rows = []
    for number, line in enumerate(lines[start + 2:], start + 3):
        if not line.startswith("|"):
            break
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        row = dict(zip(header, cells))
        row["line"] = number
        row["layer"] = int(row["layer"])
        row["target"] = row["target"].strip("`")
        row["folder"] = row["folder"].strip("`")
        row["links to"] = set() if row["links to"] in ("", "—", "-") else {
            link.strip().strip("`") for link in row["links to"].split(",")}
        row["gdal"] = row["gdal/proj"].lower().startswith("yes")
        rows.append(row)
    return rows


def strip_comments(text):
    return "\n".join(re.sub(r"#.*", "", line) for line in text.split("\n"))


def calls(text, name):
    """The argument lists (split into words) of every call `name(...)` in CMake text."""
    for match in re.finditer(r"\b" + name + r"\s*\(", text):
        depth, i = 1, match.end()
        while depth and i < len(text):
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            i += 1
        yield text[match.end():i - 1].split()


def read_cmake(root):
    files = [root / "CMakeLists.txt"] + sorted(
        path for folder in ("src", "apps", "python") for path in (root / folder).rglob("CMakeLists.txt"))
    modules, targets, links = {}, set(), {}
    for path in files:
        if not path.exists():
            continue
        text = strip_comments(path.read_text(encoding="utf-8"))
        where = path.relative_to(root)
        for words in calls(text, "dsmplan_module"):
            target = "dsmplan_" + words[0]
            modules[target] = where
            targets.add(target)
            linked = [w for w in words[1:] if w not in ("PUBLIC", "PRIVATE", "SOURCES")]
            links.setdefault(target, set()).update(linked)
        for kind in ("add_executable", "add_library", "pybind11_add_module"):
            for words in calls(text, kind):
                targets.add(words[0])
        for words in calls(text, "target_link_libraries"):
            linked = [w for w in words[1:] if w not in ("PUBLIC", "PRIVATE", "INTERFACE")]
            links.setdefault(words[0], set()).update(linked)
    return modules, targets, links


def check(root, doc):
    rows = read_table(doc)
    modules, targets, links = read_cmake(root)
    offences = []
    by_target = {row["target"]: row for row in rows}
    by_module = {row["module"]: row for row in rows}
    for before, row in zip(rows, rows[1:]):
        if row["layer"] > before["layer"]:
            offences.append(f"{doc.name}:{row['line']}: {row['module']} (layer {row['layer']}) is listed below "
                            f"{before['module']} (layer {before['layer']}): rows run from the top layer down")
    for row in rows:
        if row["target"] not in targets:
            offences.append(f"{doc.name}:{row['line']}: module {row['module']} names target {row['target']}, "
                            f"which no CMakeLists.txt makes")
    for target, where in sorted(modules.items()):
        if target not in by_target:
            offences.append(f"{where}: dsmplan_module({target[len('dsmplan_'):]}) is a module that "
                            f"{doc.name} does not name")
    for row in rows:
        target, layer = row["target"], row["layer"]
        declared = links.get(target, set())
        stages = {t for t in declared if t in by_target}
        for linked in sorted(stages):
            other = by_target[linked]
            if other["layer"] >= layer:
                side = "above it" if other["layer"] > layer else "on its own layer"
                offences.append(f"{target} (layer {layer}) links {linked} (layer {other['layer']}), a stage {side}")
        unknown = {t for t in declared if t.startswith("dsmplan_") and t not in by_target}
        for linked in sorted(unknown):
            offences.append(f"{target} links {linked}, which {doc.name} does not name")
        named = {by_module[m]["target"] if m in by_module else "?" + m for m in row["links to"]}
        for missing in sorted(named - stages - unknown):
            offences.append(f"{doc.name}:{row['line']}: says {row['module']} links {missing.lstrip('?')}; "
                            f"its CMakeLists.txt does not")
        for extra in sorted(stages - named):
            offences.append(f"{target} links {extra}, which {doc.name}:{row['line']} does not list under "
                            f"{row['module']}'s links")
        if not row["gdal"]:
            for linked in sorted(declared & GDAL_PROJ_TARGETS):
                offences.append(f"{target} links {linked}, but {doc.name} says {row['module']} uses no GDAL/PROJ")
            folder = root / row["folder"] if row["folder"] not in ("", "—", "-") else None
            nested = {root / r["folder"] for r in rows if r is not row and r["folder"] not in ("", "—", "-")}
            if folder is not None and folder.is_dir():
                for source in sorted(folder.rglob("*")):
                    if source.suffix not in (".cpp", ".hpp", ".h", ".cc", ".inc") or any(
                            n != folder and n in source.parents and folder in n.parents for n in nested):
                        continue
                    if GDAL_PROJ_INCLUDE.search(source.read_text(encoding="utf-8", errors="replace")):
                        offences.append(f"{source.relative_to(root)} includes GDAL or PROJ, but {doc.name} "
                                        f"says {row['module']} uses none")
    return rows, offences


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("root", type=pathlib.Path)
    parser.add_argument("--doc", type=pathlib.Path)
    parser.add_argument("--expect", action="append", default=[])
    args = parser.parse_args()
    root = args.root.resolve()
    doc = (args.doc or root / "docs" / "architecture.md").resolve()
    rows, offences = check(root, doc)
    for offence in offences:
        print(f"architecture: {offence}")
    if args.expect:
        missed = [text for text in args.expect if not any(text in offence for offence in offences)]
        for text in missed:
            print(f"architecture: the broken tree should have given an offence containing '{text}'")
        return 1 if missed or not offences else 0
    if offences:
        print(f"architecture: {len(offences)} offences; fix the CMakeLists.txt or {doc.name}'s table")
        return 1
    print(f"architecture: {len(rows)} modules, every link downward, as {doc.name} says")
    return 0


if __name__ == "__main__":
    sys.exit(main())
