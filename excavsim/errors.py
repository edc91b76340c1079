"""The package's exceptions. Messages say what was given, what is allowed, and where."""


class ExcavsimError(Exception):
    """Base of every error excavsim raises on purpose; the CLI prints these without a traceback."""


class ConfigError(ExcavsimError):
    """A configuration file or value is invalid: the message names the file, the field and what is allowed."""


class ModelError(ExcavsimError):
    """The MuJoCo model lacks an element the code needs, or is not shaped as the code assumes."""
