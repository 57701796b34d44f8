"""PhysRig soft-body refinement: MLS-MPM in NVIDIA Warp driven by the animated skeleton, and its inverse fit.

Modules: sampling (particles from a mesh), materials (prototypes, presets), drivers (driving points from the
skeleton), kernels + solver (one substep, forward and adjoint), simulate (frame rollouts with checkpoints),
scene + refine + refine_stage (the pipeline's `refine` stage), fit + lbs_fit + fit_experiment (`rigforge fit`),
measures (volume, chamfer). Only kernels, solver and simulate import warp; import them lazily.
"""
