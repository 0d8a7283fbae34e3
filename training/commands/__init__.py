"""The console scripts, one thin module each: parse the command line into a dataclass, load
the case (bad input fails here), call the libraries (``training.runs``, ``training.search``,
``training.eventfloor``, the stages), exit with a status. Nothing imports a command
(``tests/test_layering.py``); run one in-process through its ``main(argv)`` or as
``python -m training.commands.NAME``."""
