"""python -m deformkit.batch: the deformkit-batch command (see cli.py)."""
import sys

from .cli import main

if __name__ == "__main__":  # a spawned pool process imports this module too: it must not run a batch
    sys.exit(main())
