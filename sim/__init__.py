"""The commands (one file per ``make`` target at this level: ``run.py`` is ``make sim``) and what they run on:

* ``compile/``: Verilator builds of the kernel and its harnesses, described once (``kernel_build.py``);
* ``drive/``: running a step on the RTL (compiled harness or cocotb) and the options that name it;
* ``compare/``: the RTL against the golden model (bits), the cycle model (retire cycles) and the exact reference;
* ``report/``: run results, reports, plots, waveform views and the thesis's figures;
* ``fit/``: the resource model, Yosys figures and the fit studies;
* ``parallel/``: the executor that spreads independent points;
* ``remedies/``: the price of the stability remedies;
* ``coverage/``: ``make coverage``; ``harness/``: the compiled harness's C++.
"""
