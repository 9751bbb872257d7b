"""ekf — the estimation engine, free of rail and GNSS knowledge.

Owns: the state layout object, continuous-discrete extended Kalman filtering of models
given as CasADi functions (RK4 propagation, per-sample continuous measurements whose
noise is correlated with the process noise, discrete updates of any dimension),
innovation statistics and chi-square gating, an RTS smoother, and multiple-model banks.
Imports nothing else of the project.
"""
