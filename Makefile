# Two commands on a fresh machine:  make reproduce   and   make test
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install reproduce reproduce-quick references real-robot real-robot-suite results test test-all test-torch-range lint docs bench clean

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[all,test,docs]'
	touch $(STAMP)

install: $(STAMP)

reproduce: $(STAMP)
	$(BIN)/softrnn reproduce -o out/reproduce

# COMPARE=REF: then compare the accuracy figures with the reference REF (CI: docs/results/reference-quick)
reproduce-quick: $(STAMP)
	$(BIN)/softrnn reproduce --quick -o out/reproduce-quick $(if $(COMPARE),--compare $(COMPARE))

# Both committed references regenerated from scratch in one go: the full run into docs/results/reference
# and the quick run into docs/results/reference-quick (report.json, report.md, run.json, the figures the
# reference shows), then the README and the results page rendered from them (make results). A change
# that moves a figure on purpose runs this and commits the new references with it, saying why
# (NOTES="..." goes into each run.json).
references: $(STAMP)
	rm -rf out/references
	$(BIN)/softrnn reproduce -o out/references/reproduce
	$(BIN)/softrnn reproduce --quick -o out/references/reproduce-quick
	NOTES="$(NOTES)" $(BIN)/python -c "import os; from softrnn.reproduce.compare import save_reference as s; \
		s('out/references/reproduce', 'docs/results/reference', notes=os.environ['NOTES']); \
		s('out/references/reproduce-quick', 'docs/results/reference-quick', notes=os.environ['NOTES'])"
	$(MAKE) results

# The real-robot benchmark on recordings in the layout of docs/guide/real-robots.md:
#   make real-robot DATA=path/to/opencr-tdcr-v6
DATA ?= data/opencr-tdcr-v6
real-robot: $(STAMP)
	mkdir -p out/real-robot
	$(BIN)/softrnn lab benchmark --train $(DATA)/train.csv --validate $(DATA)/val.csv --length 0.222 \
		--segments 0.1,0.1,0.022 --json out/real-robot/benchmark.json --figure out/real-robot/benchmark.png --overwrite

# The same robot as a suite (docs/results/real-robot/suite.toml: the recordings in data/opencr-tdcr-v6/),
# the table with the offset-aligned errors; a lab adds its robot to the suite file.
real-robot-suite: $(STAMP)
	mkdir -p out/real-robot
	$(BIN)/softrnn lab benchmark --suite docs/results/real-robot/suite.toml --json out/real-robot/suite.json \
		--markdown out/real-robot/suite.md --overwrite

# The README's table of results and docs/results/index.md, rendered from the committed reference
# run in docs/results/reference (its report.json and run.json); tests/project/test_results.py
# checks that the committed files equal this rendering.
results: $(STAMP)
	$(BIN)/python -c "from softrnn.reproduce.results import update_documents as u; \
		u('docs/results/reference', 'README.md', 'docs/results/index.md')"

# The suite on TEST_WORKERS pytest-xdist worker processes (make test TEST_WORKERS=4; TEST_WORKERS=0 runs it in
# one process). --dist loadfile: a test file runs whole on one worker, so its module fixtures are made once.
# One numba and one OpenMP (PyTorch) thread per worker: the workers, not threads, share the cores.
TEST_WORKERS ?= 2
PYTEST := NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 $(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile

test: $(STAMP)
	$(PYTEST)

test-all: $(STAMP)
	$(PYTEST) -m ''

# The learn extra asks for torch>=$(TORCH_LOW),<3 (constraints.txt pins the release the figures were made
# with): the learned-model tests with each end of that range installed in a venv of its own
# (docs/guide/getting-started.md#pytorch-versions). Needs a package index with both (gigabytes).
TORCH_LOW ?= 2.5.1
TORCH_HIGH ?= <3
TORCH_TESTS ?= tests/project/test_torch_range.py tests/learned tests/cli/test_tip_only_recordings.py \
	tests/cli/test_fresh_process.py tests/cli/test_validate_on_cli.py tests/experiments tests/figures/test_overlay.py
test-torch-range:
	for end in low high; do \
		venv=.venv-torch-$$end; spec='torch==$(TORCH_LOW)'; [ $$end = high ] && spec='torch$(TORCH_HIGH)'; \
		$(PYTHON) -m venv $$venv && $$venv/bin/python -m pip install --quiet "$$spec" -e '.[all,test]' && \
		$$venv/bin/python -c "import torch; print('test-torch-range:', torch.__version__)" && \
		NUMBA_NUM_THREADS=1 $$venv/bin/python -m pytest -q $(TORCH_TESTS) || exit 1; \
	done

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks

docs: $(STAMP)
	$(BIN)/mkdocs build --strict -d site

bench: $(STAMP)
	$(BIN)/softrnn bench --overwrite --json benchmarks/results/bench.json

clean:
	rm -rf $(VENV) .venv-torch-low .venv-torch-high out build site src/*.egg-info
