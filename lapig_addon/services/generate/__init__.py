"""Generate: the look and its projector images for one projector or several, the prompt's preview as it is typed, a world look's sliders."""
