"""``python -m rollsim.geometry``."""
import sys

from rollsim.geometry.cli import main

if __name__ == "__main__":
    sys.exit(main())
