"""`python -m selfcd`: the same as the `selfcd` command."""

from .cli import main

main()
