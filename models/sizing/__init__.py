"""Number formats and memories sized to a scene: the narrowest formats within an error budget
(``format_analyzer.py``), storage narrower than the arithmetic (``mixed_storage.py``, ``mixed_layout.py``), and the
on-chip memory budget of a banded kernel (``onchip_budget.py``)."""
