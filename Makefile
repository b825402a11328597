# gyrocomp: `make run` sets up and runs the main job on sample_data/; `make test` runs the tests.
# Tests run in two pytest-xdist workers on the two cores, each with one BLAS thread (no oversubscription).
# Installs take every version from requirements/lock.txt (pyproject.toml keeps the ranges users get);
# `make lock` refreshes the lock in a clean temporary venv with every extra of pyproject.toml.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
LOCK := requirements/lock.txt
EXTRAS = $(shell $(PYTHON) -c "import tomllib; print(','.join(tomllib.load(open('pyproject.toml', 'rb'))['project']['optional-dependencies']))")

.PHONY: run test test-slow bench sample-data lock clean

$(STAMP): pyproject.toml $(LOCK)
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet -c $(LOCK) --upgrade pip
	$(BIN)/python -m pip install --quiet -c $(LOCK) -e '.[dev]'
	touch $(STAMP)

lock:
	rm -rf .lock-venv
	$(PYTHON) -m venv .lock-venv
	.lock-venv/bin/python -m pip install --quiet --upgrade pip
	.lock-venv/bin/python -m pip install --quiet '.[$(EXTRAS)]'
	mkdir -p requirements
	{ echo "# Every package a clean venv gets from: pip install '.[$(EXTRAS)]' ($$(.lock-venv/bin/python -V), $$(uname -m))."; \
	  echo "# Made by \`make lock\`; \`make run\`, \`make test\` and .ci/run install with: pip install -c $(LOCK)"; \
	  .lock-venv/bin/python -m pip freeze --all --exclude gyrocomp --exclude setuptools --exclude wheel; } > $(LOCK).tmp
	mv $(LOCK).tmp $(LOCK)
	rm -rf .lock-venv build gyrocomp.egg-info

run: $(STAMP)
	$(BIN)/gyrocomp allan sample_data/oven_train.parquet sample_data/oven_test.parquet --out out/allan.json --plot out/allan.png
	$(BIN)/gyrocomp run configs/compare.toml sample_data/oven_train.parquet --test sample_data/oven_test.parquet \
		--workers 2 --out out

test: $(STAMP)
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 $(BIN)/python -m pytest -q -m "not slow" -n 2

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

sample-data: $(STAMP)
	$(BIN)/gyrocomp simulate configs/sample/oven_train.toml --out sample_data/oven_train.parquet
	$(BIN)/gyrocomp simulate configs/sample/oven_test.toml --out sample_data/oven_test.parquet

clean:
	rm -rf out .pytest_cache
