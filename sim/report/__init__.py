"""What a run reports: its typed result and sections (``run_result.py``), the report files and the terminal summary
(``run_report.py``), the sweep's plots and Pareto front (``sweep_plot.py``, ``pareto_front.py``)."""
