"""Train: the networks of one projector fine-tuned on its capture, their choice measured on the rig."""
