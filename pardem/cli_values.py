"""The command line's value types and messages: times and lengths checked as argparse reads
them, a scene error prefixed with its file, one line for an unreadable run folder.

Stage: front (cli.py).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path


UNREADABLE = (OSError, KeyError, ValueError, TypeError, IndexError)
"""What h5py and numpy raise on a damaged or foreign output file."""


def unreadable(run_dir, error: Exception) -> str:
    """One line for output files that cannot be read (not HDF5, truncated, another format)."""
    text = str(error).strip('"') or type(error).__name__
    return (f"{run_dir}: its output files cannot be read ({text}); is it a pardem run folder, "
            "written completely?")


def seconds(text: str) -> float:
    """A time on the command line: finite and >= 0 (argparse reports the error in one line)."""
    value = float(text)  # argparse turns a ValueError into "invalid seconds value"
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"{text}: expected a finite time in seconds, >= 0")
    return value


def metres(text: str) -> float:
    """A length on the command line: finite and > 0."""
    value = float(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text}: expected a finite length in metres, > 0")
    return value


def in_file(error: Exception, scene_path: str) -> str:
    """A scene error as the user reads it: prefixed with the scene file, unless it already names
    a file or is about a command-line option (--out, --restart, --end)."""
    text, name = str(error), str(Path(scene_path))
    return text if text.startswith((name, "--")) else f"{name}: {text}"
