# skyrender: `make demo` runs the main job on the built-in DEM, `make test` runs the tests.
# Both set up everything first on a fresh machine (system LLVM, a .venv with the package).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out

.PHONY: install demo test fuzz fit-photo-confidence bench bench-render bench-skyline bench-localize bench-split bench-scale bench-real oracle train-sky-net experiment-naval2000 clean

install: $(STAMP)

$(STAMP): pyproject.toml scripts/install-system-deps.sh
	bash scripts/install-system-deps.sh
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	# the compiled kernels (the alignment, the boundary search, the k-means step) into numba's cache, once
	$(BIN)/python -m skyrender.localizer.alignment_kernel
	$(BIN)/python -m skyrender.features.boundary_kernel
	$(BIN)/python -m skyrender.features.kmeans_kernel
	touch $(STAMP)

demo: install
	$(BIN)/python -m skyrender.demo scenes/jacksboro.toml --out $(OUT)

# two test files at a time (pytest-xdist): a test's serial parts leave a core idle (2 cores: 10.9 -> 8.2 min)
test: install
	$(BIN)/ruff check skyrender tests
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

bench: bench-render bench-skyline bench-localize

# 1,000 malformed inputs across every command (seeded): exit 0/2/3, one stderr line, nothing else written
fuzz: install
	$(BIN)/python -m skyrender.diagnostics.fuzz --n 1000 --seed 0

bench-skyline: install
	$(BIN)/python -m skyrender.benchmarks.skyline_photos

# real photos (CH1 validation side) localized against an SRTM mosaic around each place
bench-real: install
	$(BIN)/python -m skyrender.benchmarks.real_localize --side validation

# the best fit of each CH1 training photo at its true position (what a localizer can hope for)
oracle: install
	$(BIN)/python -m skyrender.diagnostics.oracle --side train

bench-localize: install
	$(BIN)/python -m skyrender.benchmarks.localizer

# the CLI at scale: synthetic 600², a whole SRTM3 tile, a 1-arc-second tile, 2 x 2 tiles (time, peak RSS; ~30 min)
bench-scale: install
	$(BIN)/python -m skyrender.benchmarks.scale

# one localization's hypothesis search on 2 Dask workers against this process
bench-split: install
	$(BIN)/python -m skyrender.benchmarks.split_search --workers 2

# refit the photo confidence of the localizer from the committed rows of the 73 CH1 training-side photos (seconds;
# reproduces skyrender/localizer/photo_confidence.json); `make fit-photo-confidence FIT_FROM=` localizes them again
# first (~40 min) into experiments/ch1/confidence-train-rows.json (at b3845fc that fit differs:
# experiments/photos/em-budget/shipped/README.md)
# the fov-unknown threshold comes from the training rows localized that way (regenerate them with the localizer:
# python -m skyrender.benchmarks.real_localize --side train --fov unknown --limit 20 --no-abstain --tag unknown-train
#   --out experiments/ch1/dem-window/unknown, and --side dev (all 21) --tag unknown-dev); the second opinion is fitted on
# what its search gives each photo: those rows, and for the 5 dev photos narrower than the fov-unknown search reaches,
# python -m skyrender.benchmarks.real_localize --side dev --fov second --no-abstain --photos <them> --tag second-telephoto
#   --out experiments/ch1/telephoto-second-opinion
FIT_FROM ?= --from-rows
fit-photo-confidence: install
	$(BIN)/python -m skyrender.training.localize_fit $(FIT_FROM) --fov-unknown-rows experiments/ch1/rerank-cut-fov-unknown/bench-real-train-cut300.json \
		experiments/ch1/rerank-cut-fov-unknown/bench-real-dev-cut300.json experiments/ch1/mode-agreement/bench-real-train-rest32.json \
		--second-opinion-rows experiments/ch1/rerank-cut-fov-unknown/bench-real-train-cut300.json \
		experiments/ch1/rerank-cut-fov-unknown/bench-real-dev-cut300.json experiments/ch1/mode-agreement/bench-real-train-rest32.json \
		experiments/ch1/telephoto-second-opinion/bench-real-dev-second-telephoto.json
	# the same fit for skylines a person gives (localize --skyline / --sky-mask), from the training side localized
	# from its masks' skylines (experiments/ch1/given-skyline/README.md says how those rows are made)
	$(BIN)/python -m skyrender.training.localize_fit --from-rows --rows experiments/ch1/given-skyline/rows-training.json \
		--fov-unknown-rows experiments/ch1/given-skyline/bench-real-dev-true-skyline-unknown.json \
		experiments/ch1/given-skyline/bench-real-train-true-skyline-unknown.json \
		--out skyrender/localizer/given_skyline_confidence.json

# retrain the sky network and refit the boundary search on the training split (CPU, ~10 min);
# reproduces skyrender/features/weights/ for the seed
train-sky-net: install
	$(BIN)/python -m pip install -q -e '.[dev,train]'
	$(BIN)/python -m skyrender.training.sky_net --steps 12000 --seed 1 --renders 0 --threads 1
	$(BIN)/python -m skyrender.training.skyline_fit

# the paper's experiment: 2 scenes x 2 seeds x 25 rendered views, three configurations (~40 min);
# datasets are written from their recipes on the first run, finished views are skipped on the next
experiment-naval2000: install
	$(BIN)/skyrender experiment experiments/naval2000.toml

bench-render: install
	$(BIN)/python -m skyrender.benchmarks.renderer

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
