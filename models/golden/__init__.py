"""The golden model of the kernel: Bullet's GPU contact and friction passes (``contact_solver.py``) and integration
(``integrator.py``) in a fixed operation order (``OPERATION_ORDER.md``), every operation rounded by the number format;
the remedies a step can add (shock propagation, Box2D's soft contact, substeps, warm starting); Bullet 2's own solver
for parity with pybullet (``bullet2_solver.py``); and the steps after 1, 2, 4, ... iterations from one solve
(``iteration_ladder.py``)."""
