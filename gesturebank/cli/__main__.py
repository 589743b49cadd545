"""`python -m gesturebank.cli`: the `gesturebank` command."""

from gesturebank.cli import main

main()
