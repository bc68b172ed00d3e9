# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors on one object (issue 36), numpy + OpenCV only: the joint classical model in camera
space, its box-constrained compensation, geometric blend weights, the black level of overlaps, coverage.
(Not shipped: the numpy fake rig of K projectors and one camera the tests use, tools/fakes/fake_rig.)

Entry points for the benchmarks (`bench multi`; the stack's PSA gain the tests measure is
tools/bench/stack_gain.stack_psa_gain, not shipped):
- PSA on the joint reach (joint_psa, torch):
    stylize.stylize_joint(model, surface, prompt, backend, ..., psa=True, psa_settings=None) -> JointLook
        (.target, .frames, .without: the look without PSA, .psa: what PSA did);
    joint_psa.simulated_psnr(model, look, mask) and joint_psa.joint_surface_models(model, shape, on_object).
- Refinement of all projectors on the rig: refine/joint (JointRefinement, in camera space; the rounds are
  refine/loop's, shared with one projector's projector-space Refinement).
"""
