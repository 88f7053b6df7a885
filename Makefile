# Two commands for a fresh machine:
#   make run   set up, then run the paper's experiments (results/) and the contact protocol (results/contact/);
#              about 3.5 minutes and 1.3 GB from a fresh clone on 2 cores (the converged references ship as data)
#   make test  set up, then run the test suite (slow checks skipped)
#   make test-slow  the test suite with the slow checks
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test test-slow docs setup clean clean-numba

# Headless OpenGL (EGL on Mesa's software renderer) for the figures; installed where apt-get can, else skipped.
GL_PACKAGES := libegl1 libegl-mesa0 libgl1-mesa-dri

$(STAMP): pyproject.toml
	-@dpkg -s $(GL_PACKAGES) >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq $(GL_PACKAGES); } >/dev/null 2>&1 \
		|| echo "note: could not install $(GL_PACKAGES); figures need OpenGL"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test,fast]"
	touch $(STAMP)

setup: $(STAMP)

run: $(STAMP)
	$(BIN)/tissuesim experiment --output results
	$(BIN)/tissuesim render --output results --report results/report.md --if-available
	$(BIN)/tissuesim experiment --protocol contact --output results/contact

test: $(STAMP)
	$(BIN)/python -m pytest -q

docs: $(STAMP)
	$(BIN)/mkdocs build --strict

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q --run-slow

clean:
	rm -rf $(VENV) results .pytest_cache site

# Numba caches a compiled kernel by its own source file: after editing a module whose functions others inline
# (layer/hinge_kernels.py), the callers' caches are stale.
clean-numba:
	find src -name '*.nbi' -delete -o -name '*.nbc' -delete
