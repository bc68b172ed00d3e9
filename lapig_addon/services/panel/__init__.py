"""The panel's decisions: what is done, stale or missing, what blocks each step, what fits a line."""
