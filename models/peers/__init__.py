"""The peers a user would pick instead of the FPGA kernel, run on the same frame.

* :mod:`models.peers.batching`: Bullet3's greedy constraint batching (no dynamic body twice in a batch).
* :mod:`models.peers.warp_pgs`: Bullet's batched GPU PGS scheme written in NVIDIA Warp (CPU, and CUDA where present).
* :mod:`models.peers.mujoco_peer`: the same frame as an MJCF model stepped by MuJoCo's PGS solver.
"""
