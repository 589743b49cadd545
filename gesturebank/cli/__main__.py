"""`python -m gesturebank.cli`: the `gesturebank` command."""

from gesturebank.cli import main

if __name__ == "__main__":  # importing it (a module walk) runs nothing
    main()
