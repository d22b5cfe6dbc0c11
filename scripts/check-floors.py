#!/usr/bin/env python3
"""Checks the include lines of src/ against its floors (docs/layout.md).

Every `#include "x"` of a file in src/ must name a file that exists from the one include root src/
("sh/basis.h"; the GLSL includes of src/glsl name each other as siblings), and lie in the includer's folder or on a lower floor. Angle brackets are
for dependencies and the headers the build generates (<shprobe/version.h>, <shprobe/*_spirv.h>).
Prints each offending line as FILE:LINE: reason, and exits 1 if there is any.
"""
import pathlib
import re
import sys

# folder -> floor; a folder includes its own files and those of lower floors only.
FLOORS = {
    "common": 0, "glsl": 0,
    "sh": 1, "vk": 1,
    "image": 2,
    "formats": 3,
    "scene": 4,
    "gpu": 5,
    "render": 6,
    "app": 7,
}
GENERATED = re.compile(r"shprobe/(version|shprobe(_[a-z]+)?_spirv)\.h")
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def resolve(src, includer, name):
    # GLSL has no include root of its own: src/glsl's files include each other by name.
    beside = [includer.parent / name] if includer.parent.name == "glsl" else []
    for candidate in beside + [src / name]:
        if candidate.is_file():
            return candidate.resolve()
    return None


def check_file(src, path):
    folder = path.relative_to(src).parts[0]
    problems = []
    for number, line in enumerate(path.read_text().splitlines(), 1):
        match = INCLUDE.match(line)
        if not match:
            continue
        bracket, name = match.groups()
        where = f"{path}:{number}: {line.strip()}"
        if bracket == "<":
            if name.startswith("shprobe/") and not GENERATED.fullmatch(name):
                problems.append(f'{where}: the project\'s own headers are included as "folder/file.h"')
            continue
        target = resolve(src, path, name)
        if target is None:
            problems.append(f"{where}: no such file in src/")
            continue
        to = target.relative_to(src.resolve()).parts[0]
        if to != folder and FLOORS[to] >= FLOORS[folder]:
            problems.append(f"{where}: {folder}/ (floor {FLOORS[folder]}) may not include {to}/ "
                            f"(floor {FLOORS[to]})")
    return problems


def main():
    src = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent / "src")
    folders = sorted(p.name for p in src.iterdir() if p.is_dir())
    unknown = [f for f in folders if f not in FLOORS]
    problems = [f"{src / f}: a folder of src/ that is on no floor (scripts/check-floors.py)" for f in unknown]
    files = sorted(p for p in src.rglob("*") if p.suffix in (".h", ".cpp", ".glsl") and p.is_file())
    for path in files:
        if path.relative_to(src).parts[0] in FLOORS:
            problems += check_file(src, path)
    for problem in problems:
        print(problem)
    print(f"check-floors: {len(files)} files, {len(problems)} includes against the floors")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
