"""Benchmarks of the simulator (``softrnn bench``; ``benchmarks/bench_simulator.py``)."""
