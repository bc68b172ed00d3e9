"""What CompenNeSt and PCNet share: the trunk of layers of the same shapes, their initialisation, the summary line."""
from torch import nn


def count_parameters(module: nn.Module, trainable_only: bool = False) -> int:
    """Number of scalar parameters (optionally only those with requires_grad)."""
    return sum(p.numel() for p in module.parameters() if p.requires_grad or not trainable_only)


def describe(module: nn.Module) -> str:
    """One-line human readable summary, e.g. for logs and UI labels."""
    name = getattr(module, "ARCH_NAME", type(module).__name__)
    return f"{name} ({count_parameters(module):,} parameters)"


class Net(nn.Module):
    ARCH_NAME = ""

    def add_trunk(self) -> None:
        """conv2 to conv6, the same in both networks. Made in this order: the seeded initialisation follows the
        order the layers were registered in."""
        self.conv2 = nn.Conv2d(32, 64, 3, 2, 1)
        self.conv3 = nn.Conv2d(64, 128, 3, 1, 1)
        self.conv4 = nn.Conv2d(128, 256, 3, 1, 1)
        self.conv5 = nn.Conv2d(256, 128, 3, 1, 1)
        self.tconv1 = nn.ConvTranspose2d(128, 64, 3, 2, 1, output_padding=1)
        self.tconv2 = nn.ConvTranspose2d(64, 32, 2, 2, 0)
        self.conv6 = nn.Conv2d(32, 3, 3, 1, 1)

    def init_weights(self) -> None:
        for m in self.modules():
            if isinstance(m, nn.Conv2d):  # spec: Kaiming on Conv2d only
                nn.init.kaiming_normal_(m.weight)

    def describe(self) -> str:
        return describe(self)
