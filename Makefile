# mmocap — run `make help` for the list of targets.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
# Example plugins, installed (not editable: Hydra finds their configs in site-packages) so
# that the test suite runs them like a user's own plugin.
PLUGINS       := plugins/mmocap-pycma
PLUGIN_FILES  := $(shell find $(PLUGINS) -name '*.py' -o -name '*.toml' -o -name '*.yaml')

.DEFAULT_GOAL := help
.PHONY: help install demo optimizers test test-all clean bench table1 table2

help: ## Show this help
	@grep -hE '^[a-zA-Z0-9_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN {FS = ":.*## "}; {printf "  \033[36m%-12s\033[0m %s\n", $$1, $$2}'

$(STAMP): pyproject.toml $(PLUGIN_FILES)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	$(PY) -m pip install --quiet $(addprefix ./,$(PLUGINS))
	@touch $(STAMP)

install: $(STAMP) ## Create .venv; install mmocap, its test dependencies and the example plugins

demo: $(STAMP) ## Generate synthetic S1 walking, track it with CMA-ES, write outputs/demo/
	$(PY) -m mmocap +experiment=demo

optimizers: $(STAMP) ## Demo sequence with every built-in optimiser, holistic and hierarchical; table in outputs/tables/
	rm -rf outputs/optimizers
	$(PY) -m mmocap -m +experiment=demo optimizer=cmaes,de,pso,apf,psapf strategy=holistic,hierarchical \
		overlays=0 progress=false hydra.sweep.dir=outputs/optimizers
	@mkdir -p outputs/tables
	$(PY) -m mmocap.report.summaries outputs/optimizers --csv outputs/tables/optimizers.csv \
		| tee outputs/tables/optimizers.md

# BLAS on one thread: its idle threads spinning beside OpenCL's or the workers' would
# inflate CMA-ES's share of a frame many times over on a small machine.
BENCH := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PY) -m mmocap.bench

bench: $(STAMP) ## Evaluator benchmark, 27393 vertices: time per model-view and per CMA-ES frame (500, 1500 evaluations); outputs/tables/bench_*
	$(BENCH) all --vertices 27393 --budgets 500,1500 --prefix bench_

table1: $(STAMP) ## Cano Table 1 and Fig. 3 for this machine: CMA-ES frame times, 3 meshes x 4 budgets (about 10 min); outputs/tables/table1.*
	$(BENCH) table1

table2: $(STAMP) ## Cano Table 2 for this machine: time per model-view per backend and mesh; outputs/tables/table2.*
	$(BENCH) table2

test: $(STAMP) ## Run the fast test suite
	$(PY) -m pytest -q

test-all: $(STAMP) ## Run every test, the slow ones included
	$(PY) -m pytest -q -m ''

clean: ## Remove generated outputs (keeps .venv)
	rm -rf outputs/*
