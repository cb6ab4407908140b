# leakdiag: `make demo` and `make test` work on a fresh machine (they create .venv themselves).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install demo test bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(BIN)/leakdiag demo --out demo-output

# two processes (pytest-xdist): the suite took 8.5-10 min in one on this 2-core machine
test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2

bench: $(STAMP)
	$(BIN)/python -m pytest perf -q -p no:randomly --benchmark-columns=min,mean,rounds --benchmark-sort=name

clean:
	rm -rf $(VENV) demo-output .pytest_cache build src/*.egg-info
