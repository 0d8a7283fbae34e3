# Two commands: `make demo` and `make test`, each sets up .venv by itself on a fresh machine.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
export SDL_VIDEODRIVER := dummy
export SDL_AUDIODRIVER := dummy
export PYGAME_HIDE_SUPPORT_PROMPT := 1
# Python's bytecode caches are written (into __pycache__, ignored by git) even where the
# environment turns them off (PYTHONDONTWRITEBYTECODE, set on the development machines): without
# them pytest rewrites the asserts of every test module again in each of the gate's workers at
# every run (collection 13.3 s instead of 7.5 s a worker) and each process compiles the package.
unexport PYTHONDONTWRITEBYTECODE

.PHONY: demo test test-slow test-nightly test-ray test-wheel docs lint bench clean

# torch is pinned first and on its own: an unpinned torch (pulled by stable-baselines3)
# would fetch a CUDA build of several GB. On a machine with only the public package index,
# PyPI's torch wheel for Linux pulls CUDA libraries too: take the CPU build from PyTorch's
# index with `make test TORCH_INDEX=https://download.pytorch.org/whl/cpu` (docs/getting-started.md).
TORCH_INDEX ?=
$(VENV)/.installed: setup.cfg pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet torch==2.13.0 $(if $(TORCH_INDEX),--index-url $(TORCH_INDEX))
	$(PY) -m pip install --quiet -e '.[dev,onnx,ifc,mspdi-test,plan]'
	touch $@

demo: $(VENV)/.installed
	$(VENV)/bin/cmdp-simulate --gif --out out/demo

# The gate (about 2 min on 2 cores), the slow set (CI) and the nightly set (the full sweeps,
# before a release; not in CI): docs/testing.md says what each covers and how long it takes.
# The gate runs on both cores (pytest-xdist): `worksteal` hands out tests one by one and lets
# an idle worker take the other's queued ones, so the last heavy file does not leave a core
# idle (a module's fixture may then be made on both workers; loadfile was ~5 % slower).
# The slow set too: its module fixtures are imported IFC models (seconds), no trained model,
# and loadfile left one worker with the whole of test_ifc.py (a third of the set's time).
test: $(VENV)/.installed
	$(PY) -m pytest -q -n 2 --dist worksteal -m "not slow and not nightly"

test-slow: $(VENV)/.installed
	$(PY) -m pytest -q -n 2 --dist worksteal -m "slow and not nightly"

test-nightly: $(VENV)/.installed
	$(PY) -m pytest -q -m nightly

# The Ray backend's tests (tests/test_ray.py, marker `ray`, a two-node Ray cluster on this
# machine) in a venv of their own: the default install has no Ray (ray 2.60.0 adds about
# 240 MB installed, about a minute to install here). `make test` skips them.
RAY_VENV := .venv-ray
$(RAY_VENV)/.installed: setup.cfg pyproject.toml
	$(PYTHON) -m venv $(RAY_VENV)
	$(RAY_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(RAY_VENV)/bin/python -m pip install --quiet torch==2.13.0 $(if $(TORCH_INDEX),--index-url $(TORCH_INDEX))
	$(RAY_VENV)/bin/python -m pip install --quiet -e '.[dev,onnx,ray]'
	touch $@

test-ray: $(RAY_VENV)/.installed
	$(RAY_VENV)/bin/python -m pytest -q -m ray

# Installs as a user does: the sdist and the wheel built from the tracked files, checked to carry
# every tracked package file, installed without -e into a fresh venv (torch==2.13.0 first), then
# every module imported and cmdp-simulate --seed 0 and cmdp-evaluate --help run from a folder
# outside the checkout (tools/test_wheel.sh; about 7-10 min, mostly installing; docs/testing.md).
test-wheel:
	PYTHON=$(PYTHON) TORCH_INDEX=$(TORCH_INDEX) bash tools/test_wheel.sh

# The docs site into site/, strict: a broken link, a missing page or an unreadable docstring fails.
$(VENV)/.docs-installed: $(VENV)/.installed setup.cfg
	$(PY) -m pip install --quiet -e '.[docs]'
	touch $@

docs: $(VENV)/.docs-installed
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir site

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check .

bench: $(VENV)/.installed
	$(PY) benchmarks/bench_env.py

clean:
	rm -rf $(VENV) $(RAY_VENV) out runs site
