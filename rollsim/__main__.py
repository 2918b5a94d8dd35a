from rollsim.cli import entry

entry()
