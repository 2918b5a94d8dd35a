"""``python -m rollsim``."""
from rollsim.cli import entry

if __name__ == "__main__":
    entry()
