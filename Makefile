# skyrender: `make demo` runs the main job on the built-in DEM, `make test` runs the tests.
# Both set up everything first on a fresh machine (system LLVM, a .venv with the package).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out

.PHONY: install demo test bench bench-render bench-skyline bench-localize clean

install: $(STAMP)

$(STAMP): pyproject.toml scripts/install-system-deps.sh
	bash scripts/install-system-deps.sh
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $(STAMP)

demo: install
	$(BIN)/python -m skyrender.demo scenes/jacksboro.toml --out $(OUT)

test: install
	$(BIN)/python -m pytest -q

bench: bench-render bench-skyline bench-localize

bench-skyline: install
	$(BIN)/python -m skyrender.benchmarks.skyline_photos

bench-localize: install
	$(BIN)/python -m skyrender.benchmarks.localizer

bench-render: install
	$(BIN)/python -m skyrender.benchmarks.renderer

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
