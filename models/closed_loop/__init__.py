"""Many steps in a row: pybullet's collision detection with our solver and integrator (``loop.py``), the bodies'
paths (``trajectory.py``), and the hard-case suite judged on physical quantities (``hard_cases.py``)."""
