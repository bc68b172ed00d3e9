"""A simulated projector window that records what it presents, for the tests of live output on several windows."""
from lapig.tools.fakes.simulated_window import SimulatedWindow


class Recording(SimulatedWindow):
    """A simulated window that keeps every presented frame's red mean."""

    def __init__(self, size):
        super().__init__(size, present_s=0.0005)
        self.reds = []

    def present(self):
        t = super().present()
        self.reds.append(float(self.shown[..., 0].mean()))
        return t
