"""The package's face: its version, the env's name, and the ``--version`` flag every command
shows them with. Light on purpose (no import of the simulation), so that ``setup.cfg`` reads
the version from here without building anything (``attr: cmdp_pymunk.about.__version__``).
The built-in cases' paths (``BUILTIN_CASE``, ``TINY_CASE``, ...) live with the case files in
``cmdp_pymunk.cases.load``; the package re-exports both."""

__version__ = "0.2.0"
ENV_NAME = "cmdp_pymunk_v1"  # the PettingZoo env's name and version (CMDPEnv.metadata)


def add_version_flag(parser) -> None:
    """``--version`` on a command-line parser: the package version and the env's name."""
    parser.add_argument("--version", action="version",
                        version=f"%(prog)s {__version__} ({ENV_NAME})")
