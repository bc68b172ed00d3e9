"""Light in real units: the Light Report, its job, the export's sidecar, the dose cap."""
