"""Capture: the capture job and its two ways, the newest capture, Check the Rig."""
