"""Real rigs behind the seams of services/ports: the device factory of a projector window and a camera
(real_rig), and live output on the projector window (live_output). No bpy: the headless commands, the
panel and tests/addon all use them."""
