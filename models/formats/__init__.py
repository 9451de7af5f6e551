"""The data formats everything else builds on: number formats with the kernel's bit-accurate arithmetic
(``number_format.py``) and the frame, one captured simulation step, with its file format and its inertia convention
(``frame.py``)."""
