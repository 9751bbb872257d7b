"""strapdown — inertial navigation physics.

Owns: normal gravity and Earth/transport rates, body/navigation frames and Euler
kinematics (DCM body->ENU from yaw, pitch, roll and the Euler-rate matrix derived from
it), the full 9-state and the track-constrained (reduced) mechanizations as CasADi
functions with their Jacobians, fixed-step RK4 over IMU samples, and IMU error models
with grade presets. Uses the Earth model of `trackmodel.earth`.
"""
