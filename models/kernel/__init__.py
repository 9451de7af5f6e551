"""The kernel's contract on the host side: its registers and error codes (``register_map.py``), the bits on its
streams (``stream_format.py``), a step as the kernel runs it (``kernel_job.py``), the window kernel's plan
(``record_window.py``), the banked body velocities and delay lines of a build (``body_banks.py``, ``delay_lines.py``),
the pipes' word layouts (``kernel_vectors.py``), and the stimuli that test it (``bad_input.py``,
``extreme_stimulus.py``)."""
