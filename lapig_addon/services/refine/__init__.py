"""Refine: the closed-loop refinement job and its two ways."""
