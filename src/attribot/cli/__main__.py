"""`python -m attribot.cli`: the `attribot` command."""

from attribot.cli import main

main()
