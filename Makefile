# gyrocomp: `make run` sets up and runs the main job on sample_data/; `make test` runs the tests.
# Tests run in two pytest-xdist workers on the two cores, each with one BLAS thread (no oversubscription).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test test-slow bench sample-data clean

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

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
