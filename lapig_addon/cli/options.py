"""Command-line options that set a panel setting: the same range (services/limits.py), checked before a
command opens a .blend or allocates anything."""
from __future__ import annotations

from ..services.limits import LIMITS


def ranged_option(parser, flag: str, setting: str, help: str, type=int, **kwargs):
    """parser.add_argument(flag) for the LIMITS entry `setting`; its range is added to the help."""
    action = parser.add_argument(flag, type=type, help=f"{help}; {LIMITS[setting].describe()}", **kwargs)
    ranged = parser.get_default("ranged_options") or {}
    parser.set_defaults(ranged_options={**ranged, action.dest: (flag, setting)})


def check_ranges(args):
    """ValueError naming the first given option that is out of its setting's range."""
    for dest, (flag, setting) in getattr(args, "ranged_options", {}).items():
        value = getattr(args, dest)
        problem = LIMITS[setting].problem(value) if value is not None else ""
        if problem:
            raise ValueError(f"{flag}: {problem}")
