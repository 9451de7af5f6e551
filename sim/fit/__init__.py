"""Does a design fit its device: the resource model (``resource_model.py``, on the Yosys figures of
``generated/resource_figures.json`` that ``yosys_figures.py`` makes) and the studies built on it: the platform fit of
the built configurations, the redesign levers, body banks, the tangent basis on chip and mixed storage."""
