#!/usr/bin/env bash
# Install the package as a user does and run its commands: `make test-wheel` (and CI).
#
# 1. Copy the files git tracks (a fresh clone's, with this tree's edits) into a temporary folder,
#    so that an untracked module here cannot hide one that a .gitignore line keeps out of git.
# 2. Build the sdist, and the wheel from the sdist (`python -m build`), in a fresh venv.
# 3. tools/check_wheel.py: the wheel and the sdist carry every tracked package file.
# 4. Install the wheel (not -e; torch pinned first: an unpinned one fetches a CUDA build of
#    several GB) and, from a temporary folder outside the checkout, import every module,
#    run `cmdp-simulate --seed 0` and `cmdp-evaluate --help`.
#
# PYTHON picks the interpreter, TORCH_INDEX an index for torch's CPU build (Makefile), and
# KEEP=1 keeps the temporary folder. docs/testing.md says how long it takes.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
PYTHON="${PYTHON:-python3}"
TORCH_INDEX="${TORCH_INDEX:-}"
TMP="$(mktemp -d "${TMPDIR:-/tmp}/cmdp-wheel.XXXXXX")"
if [[ "${KEEP:-0}" == 1 ]]; then
    echo "test-wheel: keeping $TMP"
else
    trap 'rm -rf "$TMP"' EXIT
fi
START=$SECONDS
step() { echo "test-wheel: [$((SECONDS - START)) s] $*"; }

step "copying the tracked files into $TMP/src"
mkdir -p "$TMP/src" "$TMP/dist" "$TMP/run"
# a tracked file deleted in this tree is skipped (as the commit would lack it)
(cd "$ROOT" && git ls-files -z | while IFS= read -r -d '' f; do [[ -e "$f" ]] && printf '%s\0' "$f"; done \
    | tar --null -T - -cf -) | tar -xf - -C "$TMP/src"

step "a fresh venv, torch==2.13.0 first"
"$PYTHON" -m venv "$TMP/venv"
VPY="$TMP/venv/bin/python"
"$VPY" -m pip install --quiet --upgrade pip
"$VPY" -m pip install --quiet torch==2.13.0 ${TORCH_INDEX:+--index-url "$TORCH_INDEX"}
"$VPY" -m pip install --quiet build==1.6.1

step "building the sdist and the wheel from it"
"$VPY" -m build --outdir "$TMP/dist" "$TMP/src" > "$TMP/build.log" 2>&1 \
    || { cat "$TMP/build.log"; exit 1; }
WHEEL="$(ls "$TMP"/dist/*.whl)"
SDIST="$(ls "$TMP"/dist/*.tar.gz)"

step "installing $(basename "$WHEEL") (not editable)"
"$VPY" -m pip install --quiet "$WHEEL"
"$VPY" -m pip check
# the archives against the tracked files (the checker takes --version from the installed
# package, as every command does)
"$VPY" "$ROOT/tools/check_wheel.py" --root "$ROOT" "$WHEEL" "$SDIST"

# from a folder outside the checkout: nothing here can be imported from the current folder
cd "$TMP/run"
step "importing every module of the installed packages"
"$VPY" - <<'EOF'
import importlib, pkgutil, sys
failed = []
for top in ("cmdp_pymunk", "agents", "training", "media"):
    pkg = importlib.import_module(top)
    if "site-packages" not in pkg.__file__:
        sys.exit(f"test-wheel: {top} was imported from {pkg.__file__}, not the installed wheel")
    for info in pkgutil.walk_packages(pkg.__path__, top + "."):
        try:
            importlib.import_module(info.name)
        except ImportError as err:
            failed.append(f"{info.name}: {err}")
for line in failed:
    print(f"test-wheel: cannot import {line}", file=sys.stderr)
sys.exit(1 if failed else 0)
EOF

step "cmdp-simulate --seed 0"
"$TMP/venv/bin/cmdp-simulate" --seed 0 --out "$TMP/run/out"
for f in summary.json schedule.csv events.csv case.json gantt_tasks.png; do
    [[ -s "$TMP/run/out/$f" ]] || { echo "test-wheel: cmdp-simulate wrote no $f" >&2; exit 1; }
done

step "cmdp-evaluate --help"
"$TMP/venv/bin/cmdp-evaluate" --help > "$TMP/evaluate-help.txt"
grep -q "usage: cmdp-evaluate" "$TMP/evaluate-help.txt" \
    || { echo "test-wheel: cmdp-evaluate --help printed no usage" >&2; exit 1; }

step "passed"
