"""`python -m fallbench.cli`: the command line, as the `fallbench` script runs it."""

from fallbench.cli import main

main()
