#!/usr/bin/env python3
"""clang-tidy over Cairn's own translation units, with a cache so that an unchanged file is not checked twice.

    tools/tidy.py BUILD_DIR [--jobs N] [--cache DIR] [--nice] [PATH_PREFIX...]

BUILD_DIR holds compile_commands.json (every build exports it). The checks are the repository's .clang-tidy.
A translation unit is checked again only when its key changes: the clang-tidy version, .clang-tidy, its
compile command (with the repository's root left out, so clones share the cache) and the contents of the
source and of every repository header it includes, followed through quoted includes on its -I paths. System
headers are not in the key (as with ccache's direct mode): a package upgrade keeps the cache. The cache
(default ~/.cache/cairn-tidy) keeps the keys of clean units only; a unit with findings is checked every time.

Prints each finding as clang-tidy does and a summary line; exits 1 when there are findings, 2 on bad usage.
"""
import argparse
import concurrent.futures
import functools
import hashlib
import json
import os
import re
import shlex
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
INCLUDE_RE = re.compile(rb'^\s*#\s*include\s*"([^"]+)"', re.MULTILINE)


def include_dirs(args, directory):
    dirs = []
    for i, a in enumerate(args):
        path = None
        if a in ("-I", "-iquote") and i + 1 < len(args):
            path = args[i + 1]
        elif a.startswith("-I") and len(a) > 2:
            path = a[2:]
        if path is not None:
            dirs.append(os.path.normpath(os.path.join(directory, path)))
    return dirs


@functools.lru_cache(maxsize=None)
def read(path):
    """A file's bytes, read once per run (a header is included by many units); None if unreadable."""
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError:
        return None


def repository_headers(source, dirs):
    """The repository files `source` includes through quoted includes, transitively (itself first)."""
    seen, order, stack = set(), [], [source]
    while stack:
        path = stack.pop()
        if path in seen:
            continue
        seen.add(path)
        order.append(path)
        content = read(path)
        if content is None:
            continue
        for name in INCLUDE_RE.findall(content):
            name = name.decode()
            for d in [os.path.dirname(path)] + dirs:
                candidate = os.path.normpath(os.path.join(d, name))
                if os.path.isfile(candidate):
                    if candidate.startswith(ROOT + os.sep) and "/build" not in candidate[len(ROOT):]:
                        stack.append(candidate)
                    break
    return order


def unit_key(entry, version, config):
    args = shlex.split(entry["command"]) if "command" in entry else entry["arguments"]
    directory = entry["directory"]
    source = os.path.normpath(os.path.join(directory, entry["file"]))
    h = hashlib.sha256()
    h.update(version)
    h.update(config)
    # The command without paths into this clone or its build folder (a clean clone's are elsewhere).
    h.update(" ".join(args).replace(ROOT, "<root>").encode())
    for path in repository_headers(source, include_dirs(args, directory)):
        h.update(path.replace(ROOT, "<root>").encode())
        h.update(read(path) or b"")
    return h.hexdigest()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("build_dir")
    parser.add_argument("prefixes", nargs="*", help="only units under these paths (relative to the root)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--cache", default=os.path.join(os.path.expanduser("~"), ".cache", "cairn-tidy"))
    parser.add_argument("--nice", action="store_true", help="run clang-tidy at the lowest CPU priority")
    opts = parser.parse_intermixed_args()
    db_path = os.path.join(opts.build_dir, "compile_commands.json")
    if not os.path.isfile(db_path):
        print(f"tidy: {db_path} not found: build first (./cairn build)", file=sys.stderr)
        return 2
    if opts.jobs < 1:
        print(f"tidy: --jobs {opts.jobs} must be at least 1", file=sys.stderr)
        return 2
    with open(db_path) as f:
        entries = json.load(f)
    config_path = os.path.join(ROOT, ".clang-tidy")
    with open(config_path, "rb") as f:
        config = f.read()
    version = subprocess.run(["clang-tidy", "--version"], capture_output=True, check=True).stdout
    os.makedirs(opts.cache, exist_ok=True)

    units = []
    for entry in entries:
        source = os.path.normpath(os.path.join(entry["directory"], entry["file"]))
        rel = os.path.relpath(source, ROOT)
        if rel.startswith("..") or rel.startswith("build") or "/generated/" in rel:
            continue  # outside the repository, or generated (fastddsgen)
        if opts.prefixes and not any(rel.startswith(p.rstrip("/")) for p in opts.prefixes):
            continue
        units.append((rel, source, entry))

    def check(unit):
        rel, source, entry = unit
        key = unit_key(entry, version, config)
        stamp = os.path.join(opts.cache, key)
        if os.path.exists(stamp):
            return rel, True, "", True
        cmd = (["nice", "-n", "19"] if opts.nice else []) + [
            "clang-tidy", "-p", opts.build_dir, "--quiet", f"--config-file={config_path}", source]
        run = subprocess.run(cmd, capture_output=True, text=True)
        findings = "\n".join(line for line in run.stdout.splitlines() if line.strip())
        clean = run.returncode == 0 and " warning: " not in run.stdout and " error: " not in run.stdout
        if clean:
            open(stamp, "w").close()
        return rel, clean, findings or run.stderr.strip()[-2000:], False

    started = time.monotonic()
    dirty, cached = 0, 0
    with concurrent.futures.ThreadPoolExecutor(max_workers=opts.jobs) as pool:
        for rel, clean, text, hit in pool.map(check, units):
            cached += hit
            if not clean:
                dirty += 1
                print(text)
    print(f"tidy: {len(units)} units, {cached} unchanged since a clean check, {dirty} with findings "
          f"({time.monotonic() - started:.0f} s, .clang-tidy checks)")
    return 1 if dirty else 0


if __name__ == "__main__":
    sys.exit(main())
