"""Published figures the project compares against, as measured by their authors (never by us): the 2018 thesis's
cycles, clocks, utilisation and scene (``thesis.py``)."""
