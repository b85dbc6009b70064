# svbi developer entry points. `make demo` and `make test` each set up their own virtual env.
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
STAMP   = $(VENV)/.installed

.PHONY: demo test lint check-generated generate bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[test,sweep]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/svbi demo

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports

test: $(STAMP) lint
	$(BIN)/python -m pytest -n 2 --dist loadfile -q

check-generated: $(STAMP)
	$(BIN)/svbi generate --check

generate: $(STAMP)
	$(BIN)/svbi generate --all

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) svbi-demo build *.egg-info
