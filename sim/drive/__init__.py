"""Running a step on the RTL: the compiled Verilator harness (``harness_run.py``, ``kernel_step.py``), cocotb
(``cocotb_run.py``, ``cocotb_step.py``), the RTL as a closed loop's stepper (``rtl_stepper.py``), the fp operators'
harness (``fp_operator_harness.py``, ``fp_operator_vectors.py``), and the options ``make sim`` and ``make sweep``
share (``run_options.py``)."""
