"""``python -m rollsim.geometry``."""
import sys

from rollsim.geometry.cli import main

sys.exit(main())
