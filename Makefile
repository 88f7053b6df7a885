# Two commands for a fresh machine:
#   make run   set up, then run the paper's experiments (results/) and the contact protocol (results/contact/)
#   make test  set up, then run the test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test setup clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test,fast]"
	touch $(STAMP)

setup: $(STAMP)

run: $(STAMP)
	$(BIN)/tissuesim experiment --output results
	$(BIN)/tissuesim experiment --protocol contact --output results/contact

test: $(STAMP)
	$(BIN)/python -m pytest -q

clean:
	rm -rf $(VENV) results .pytest_cache
