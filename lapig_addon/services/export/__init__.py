"""Export: the projector images and their sidecars, crossfades, MPCDI packages."""
