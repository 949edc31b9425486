"""hardrod's benchmark harnesses, behind `scripts/bench` (cli.py).

One module per sub-command (kernels, validate, tradeoff, scaling, traffic, balance, answer,
paper with paper_report), and what they share: common.py (paths, tables, files), outputs.py
(reading a run directory), runner.py (running hardrod), stats.py (block averaging as the
program does it, MSER, drift, fits), mpi.py (the mpirun launcher, also used by the test
scripts), references.py (the physics they judge against). Standard library only at import
time; numpy, matplotlib and h5py are imported where a figure or a file needs them.
"""
