# cosserat-fsi: installation, runs and tests on two dolfinx stacks.
#
#   make run      set up the Debian stack (.venv) and run one scene        (SCENE=, OUT=, NP=, STACK=)
#   make test     set up both stacks, ruff check, the documentation build, then the test suite on each,
#                 serial and under 2 MPI ranks
#   make docs     the documentation site (Sphinx, MyST, executed tutorials) into docs/_build/html, warnings as errors
#   make test-fast  the fast tier (-m "not slow" on 2 workers, < 2 min per stack; STACK=debian|latest), for everyday work
#
# Idempotent: each venv carries a stamp file named after a hash of its install recipe and of
# pyproject.toml; pip runs only when that stamp is missing. The apt step checks with dpkg first and
# calls apt-get only for missing packages.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help
.NOTPARALLEL:

# One BLAS/OpenMP thread per MPI rank (measured: 2 threads on 1 rank made MUMPS slower).
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1
export MPLBACKEND := Agg
# gmsh meshes are cached in the repository's meshes/ (installed code defaults to ~/.cache/cosserat-fsi/meshes).
export COSSERAT_FSI_MESH_CACHE ?= $(CURDIR)/meshes
# OpenMPI refuses to run as root without these (harmless for MPICH and for non-root users).
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1

# ------------------------------------------------------------------------------------ Debian stack
APT_PACKAGES := python3-dolfinx-real python3-gmsh python3-h5py python3-yaml python3-venv \
                python3-matplotlib python3-pip libopenblas0-pthread openmpi-bin python3-paraview
SYSTEM_PYTHON := /usr/bin/python3
VENV := .venv
# numba (compiled characteristics, points/_kernels.py) from PyPI, pinned: 0.68.1 runs on Debian's numpy 1.24
# (its floor is 1.22), so pip leaves /usr/lib's numpy alone; a later numba with a higher numpy floor would
# pull a second numpy into the venv that shadows the one dolfinx 0.5.2 was built against (checked below).
# Debian's python3-numba 0.56.4 works too, but drags in scipy and compiles differently from the latest stack.
NUMBA_PIN := numba==0.68.1 llvmlite==0.50.0
# The documentation tools (make docs), pinned: the build runs with warnings as errors, so a new Sphinx or MyST
# release could fail it. myst-nb brings myst-parser (pinned too: it parses every page) and executes the
# tutorials through ipykernel; jupytext reads the tutorials' MyST notebooks. None of them needs a newer numpy.
# ipython 9 and matplotlib-inline 0.2 do not work with Debian's matplotlib 3.6 (no figure reaches a notebook).
PIP_DOCS := sphinx==9.0.4 furo==2025.12.19 myst-nb==1.4.0 myst-parser==5.2.0 jupytext==1.19.6 ipykernel==7.4.0 \
            ipython==8.39.0 matplotlib-inline==0.1.7
PIP_DEBIAN := pydantic>=2 tqdm pytest pytest-xdist pyvista ruff $(NUMBA_PIN) $(PIP_DOCS)
MPIRUN_DEBIAN := mpirun --allow-run-as-root --oversubscribe

# ------------------------------------------------------------------------------------ latest stack
VENV_LATEST := .venv-latest
PIP_LATEST := dolfinx-solver-real gmsh h5py pyyaml pydantic tqdm matplotlib pyvista pytest pytest-xdist ruff $(NUMBA_PIN)
PYENV_ROOT ?= $(HOME)/.pyenv
# A Python >= 3.12: pyenv's newest 3.12.x, else python3.12 on PATH. Override: make setup-latest PYTHON_LATEST=...
PYTHON_LATEST ?= $(or $(shell ls -d $(PYENV_ROOT)/versions/3.12*/bin/python3 2>/dev/null | sort -V | tail -n 1),$(shell command -v python3.12 2>/dev/null))
MPIRUN_LATEST := $(VENV_LATEST)/bin/mpiexec

# Stamps: a hash of the recipe line and of pyproject.toml.
hash = $(shell { printf '%s\n' '$(1)'; cat pyproject.toml; } | sha1sum | cut -c1-12)
STAMP_DEBIAN := $(VENV)/.stamp-$(call hash,$(SYSTEM_PYTHON) $(PIP_DEBIAN) no-deps-editable)
STAMP_LATEST := $(VENV_LATEST)/.stamp-$(call hash,$(PIP_LATEST) no-deps-editable)

# ------------------------------------------------------------------------------------ runs
SCENE ?= configs/schaefer_turek_2d1.yaml
OUT ?= runs/$(basename $(notdir $(SCENE)))
NP ?= 1
STACK ?= debian
ifeq ($(STACK),latest)
  RUN_VENV := $(VENV_LATEST)
  RUN_SETUP := setup-latest
  RUN_MPI := $(MPIRUN_LATEST)
else ifeq ($(STACK),debian)
  RUN_VENV := $(VENV)
  RUN_SETUP := setup
  RUN_MPI := $(MPIRUN_DEBIAN)
else
  $(error STACK must be debian or latest, not '$(STACK)')
endif
PY := $(RUN_VENV)/bin/python
LAUNCH := $(if $(filter-out 1,$(NP)),$(RUN_MPI) -n $(NP) ,)

PYTEST_FLAGS := -q -rs --durations=15
# The serial suites on two pytest-xdist workers, one per core; load with chunks of 2: the tests are handed out
# from the front of the list, two at a time, as the workers free up, and the long ones come first
# (tests/conftest.py), so both cores share the long tests and the run ends on short ones. (worksteal split the
# list in halves and load's default first chunk is a quarter of it: either way one worker took every long test
# and the run ended on it alone; worksteal: the last 4 % of the Debian suite took 260 of its 903 s.) Each worker
# frees what a test
# built after it (tests/conftest.py) and the run's last lines give the peak memory of a test process.
PYTEST_SERIAL_FLAGS := $(PYTEST_FLAGS) -n 2 --dist load --maxschedchunk 2
# Under mpirun both ranks would race on .pytest_cache.
PYTEST_MPI_FLAGS := $(PYTEST_FLAGS) -p no:cacheprovider --color=no -m mpi

.PHONY: help setup setup-latest apt run docs test test-debian test-latest test-mpi test-mpi-debian \
        test-mpi-latest test-fast lint validate sweep-c1 figures extremes study info clean distclean

help:
	@echo "make run     [SCENE=configs/x.yaml] [OUT=runs/x] [NP=1] [STACK=debian|latest]"
	@echo "make test    both stacks: ruff, the docs build, serial pytest, then -m mpi under 2 ranks"
	@echo "make docs    the documentation site into docs/_build/html (Sphinx -W: warnings are errors)"
	@echo "make test-fast [STACK=debian|latest]   pytest -n 2 -m 'not slow' (everyday work, < 2 min)"
	@echo "make setup | setup-latest | info | validate | sweep-c1 | figures | extremes | study | clean | distclean"

# ------------------------------------------------------------------------------------ setup
setup: apt $(STAMP_DEBIAN)

apt:
	@missing=""; \
	for p in $(APT_PACKAGES); do \
	  dpkg-query -W -f='$${Status}\n' "$$p" 2>/dev/null | grep -qx 'install ok installed' || missing="$$missing $$p"; \
	done; \
	if [ -z "$$missing" ]; then echo "apt: all $(words $(APT_PACKAGES)) packages installed"; exit 0; fi; \
	echo "apt: installing$$missing"; \
	sudo=""; if [ "$$(id -u)" != 0 ]; then sudo=sudo; fi; \
	$$sudo env DEBIAN_FRONTEND=noninteractive apt-get update; \
	$$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $$missing

$(STAMP_DEBIAN):
	@if ! $(VENV)/bin/python -c 'import sys' 2>/dev/null \
	   || ! grep -qx 'include-system-site-packages = true' $(VENV)/pyvenv.cfg; then \
	  echo "venv: creating $(VENV) over $(SYSTEM_PYTHON) with system site-packages"; \
	  rm -rf $(VENV); \
	  $(SYSTEM_PYTHON) -m venv --system-site-packages $(VENV); \
	fi
	$(VENV)/bin/pip install $(foreach p,$(PIP_DEBIAN),'$(p)')
	$(VENV)/bin/pip install --no-deps --no-build-isolation -e .
	@$(VENV)/bin/python -c 'import numpy, sys; sys.exit(not numpy.__file__.startswith("/usr/lib/"))' \
	  || { echo "error: $(VENV) has a numpy of its own that shadows Debian's (dolfinx 0.5.2 needs it): $$($(VENV)/bin/pip list 2>/dev/null | grep -i '^numpy ')" >&2; exit 1; }
	$(VENV)/bin/python -c 'import numpy, dolfinx, numba; print("setup: numpy", numpy.__version__, "dolfinx", dolfinx.__version__, "numba", numba.__version__)'
	@rm -f $(VENV)/.stamp-*
	@touch $@
	@echo "setup: $(VENV) ready ($@)"

setup-latest: $(STAMP_LATEST)

$(STAMP_LATEST):
	@if [ -z "$(PYTHON_LATEST)" ] || ! "$(PYTHON_LATEST)" -c 'import sys; sys.exit(sys.version_info < (3, 12))' 2>/dev/null; then \
	  echo "error: setup-latest needs Python >= 3.12: none found as $(PYENV_ROOT)/versions/3.12*/bin/python3" >&2; \
	  echo "       nor as python3.12 on PATH ('$(PYTHON_LATEST)'). Install one (e.g. pyenv install 3.12)" >&2; \
	  echo "       or pass it: make setup-latest PYTHON_LATEST=/path/to/python3.12" >&2; \
	  exit 1; \
	fi
	@if ! $(VENV_LATEST)/bin/python -c 'import sys; sys.exit(sys.version_info < (3, 12))' 2>/dev/null; then \
	  echo "venv: creating $(VENV_LATEST) with $(PYTHON_LATEST)"; \
	  rm -rf $(VENV_LATEST); \
	  "$(PYTHON_LATEST)" -m venv $(VENV_LATEST); \
	fi
	$(VENV_LATEST)/bin/pip install $(PIP_LATEST)
	$(VENV_LATEST)/bin/pip install --no-deps -e .
	@rm -f $(VENV_LATEST)/.stamp-*
	@touch $@
	@echo "setup-latest: $(VENV_LATEST) ready ($@, $$(du -sh $(VENV_LATEST) | cut -f1))"

# ------------------------------------------------------------------------------------ run
# make run                                   Debian stack, serial
# make run NP=2                              Debian stack, mpirun -n 2 (OpenMPI)
# make run STACK=latest NP=2 SCENE=configs/turek_hron_fsi2.yaml
# `make run` replaces the run of an earlier `make run` in $(OUT) (--overwrite: only once the new one is set
# up; a folder in use by a running run is still refused). RUN_FLAGS= (empty) keeps an existing run instead.
RUN_FLAGS ?= --overwrite
run: $(RUN_SETUP)
	$(LAUNCH)$(RUN_VENV)/bin/cosserat-fsi run $(SCENE) --out $(OUT) $(RUN_FLAGS)

# ------------------------------------------------------------------------------------ tests
# Every step runs even if an earlier one fails (-k); make exits non-zero if any failed.
# pytest's exit code 5 ("no tests collected") is a failure here on purpose.
test: setup setup-latest
	@$(MAKE) --no-print-directory -k lint docs test-debian test-latest test-mpi

lint: setup
	@echo "=== ruff check ==="
	$(VENV)/bin/ruff check .

# the fast tier: the tests below a few seconds each, on two pytest-xdist workers (one per core)
test-fast: $(RUN_SETUP)
	$(PY) -m pytest $(PYTEST_FLAGS) -n 2 -m "not slow"

test-debian: setup
	@echo "=== pytest: Debian stack (dolfinx 0.5.2, serial, 2 workers) ==="
	$(VENV)/bin/python -m pytest $(PYTEST_SERIAL_FLAGS)

test-latest: setup-latest
	@echo "=== pytest: latest stack (PyPI dolfinx-solver-real, serial, 2 workers) ==="
	$(VENV_LATEST)/bin/python -m pytest $(PYTEST_SERIAL_FLAGS)

test-mpi: test-mpi-debian test-mpi-latest

test-mpi-debian: setup
	@echo "=== pytest -m mpi: Debian stack, OpenMPI, 2 ranks ==="
	$(MPIRUN_DEBIAN) -n 2 $(VENV)/bin/python -m pytest $(PYTEST_MPI_FLAGS)

test-mpi-latest: setup-latest
	@echo "=== pytest -m mpi: latest stack, MPICH, 2 ranks ==="
	$(MPIRUN_LATEST) -n 2 $(VENV_LATEST)/bin/python -m pytest $(PYTEST_MPI_FLAGS)

# ------------------------------------------------------------------------------------ documentation
# Sphinx with MyST pages. The tutorials (docs/tutorials/*.md, MyST notebooks) are executed whenever Sphinx
# reads them (all of them in a fresh build); docs/scene_reference.md is generated from the scene schema
# (docs/conf.py). Warnings are errors; -T prints the traceback of an error (a failing tutorial cell) here
# rather than into a temporary file.
docs: setup
	@echo "=== sphinx-build: docs -> docs/_build/html ==="
	$(VENV)/bin/sphinx-build -T -W --keep-going -b html docs docs/_build/html

# ------------------------------------------------------------------------------------ studies
validate: $(RUN_SETUP)
	$(PY) campaigns/validate.py

# Seed figures 5-6: amplitude of the flag tip against c1 (docs/figures/seed_fig5_6_c1_sweep.png)
sweep-c1: $(RUN_SETUP)
	$(PY) campaigns/validate.py --only 'c1sweep*'

# The seed's figures 3-10 into docs/figures and docs/seed_reproduction.md (runs resume; ~30 min on 2 cores)
figures: $(RUN_SETUP)
	$(PY) campaigns/seed_figures.py

# Stability at the extremes (stiff/soft/light/heavy solid, dt x 10, high Re, mu_r/mu = 1000, tiny
# micro-inertia) into docs/extremes.md (~10 min on 2 cores)
extremes: $(RUN_SETUP)
	$(PY) campaigns/extremes.py

# Speed/accuracy ladders (studies/*.yaml) into docs/study_<name>.md + Pareto plots, then the extremes
# (hours on 2 cores;
# finished runs are kept, so it resumes)
study: $(RUN_SETUP)
	@for s in studies/*.yaml; do $(PY) -m cosserat_fsi study $$s --out docs --jobs 2 || exit 1; done
	$(PY) campaigns/extremes.py

info: setup setup-latest
	@echo "=== Debian stack ($(VENV)) ==="
	$(VENV)/bin/cosserat-fsi info
	@echo "=== latest stack ($(VENV_LATEST)) ==="
	$(VENV_LATEST)/bin/cosserat-fsi info

# ------------------------------------------------------------------------------------ cleaning
clean:
	rm -rf runs/ .pytest_cache/ build/ *.egg-info docs/_build/ docs/jupyter_execute/
	rm -f docs/scene_reference.md
	rm -f meshes/*.msh meshes/*.json
	find . -path ./.venv -prune -o -path ./.venv-latest -prune -o -path ./.git -prune -o \
	  -name __pycache__ -type d -print0 | xargs -0 rm -rf

distclean: clean
	rm -rf $(VENV) $(VENV_LATEST)
