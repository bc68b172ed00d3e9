"""What the add-on installs for the user: torch's builds and install job, the diffusion models' downloads."""
