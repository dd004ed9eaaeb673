"""``python -m inkray``: the command line."""

from inkray.cli import entry

if __name__ == "__main__":
    entry()
