"""The models: everything the RTL is checked against and everything a run reports, in pure Python.

The folders in the order of a step, each importing only the ones above it:

* ``formats/``: number formats and their bit-accurate arithmetic; the frame (one captured step) and its file;
* ``scenes/``: scenes and world files built in pybullet, their contacts captured as frames, cached;
* ``setup/``: a frame's bodies and manifolds turned into the kernel's body table and constraint rows;
* ``order/``: the order in which a pass visits the manifolds (schedules);
* ``golden/``: the golden model: the contact, friction and integration passes in the kernel's operation order;
* ``kernel/``: the kernel's contract: register map, stream layouts, a step as a job, the window plan;
* ``timing/``: the platforms and the cycle models of both kernels;
* ``exact/``: the exact limit of the scheme and the errors measured against it;
* ``sizing/``: number formats and memories sized to a scene;
* ``closed_loop/``: many steps with pybullet's collision detection, and the hard-case suite;
* ``published/``: figures others published (the thesis), which the reports compare against.
"""
