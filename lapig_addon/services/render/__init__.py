"""Render Real Capture: the job and its two ways."""
