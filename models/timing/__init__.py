"""How long a kernel takes: the platforms (DMA data paths and devices, ``platforms.py``), a kernel build's timing
shape (``kernel_shape.py``), and the cycle models of the streaming and window kernels (``stream_cycle_model.py``,
``window_cycle_model.py``, on the shared pieces of ``prediction.py``; ``cycle_model.py`` picks one for a job)."""
