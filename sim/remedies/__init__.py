"""The stability remedies priced: error against the exact reference and kernel cycles of warm starting, substeps and
shock propagation on a step (``remedy_price.py``, cached by ``remedy_step_cache.py``), a hard case closed loop through
the RTL (``soft_rtl_loop.py``), and the soft contact's tuning (``soft_tuning.py``)."""
