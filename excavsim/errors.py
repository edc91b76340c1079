"""The package's exceptions. Messages say what was given, what is allowed, and where."""


class ExcavsimError(Exception):
    """Base of every error excavsim raises on purpose; the CLI prints these without a traceback."""


class ConfigError(ExcavsimError):
    """A configuration file or value is invalid: the message names the file, the field and what is allowed."""


class ModelError(ExcavsimError):
    """The MuJoCo model lacks an element the code needs, or is not shaped as the code assumes."""


ECHO_CHARS = 80  # longest given value a message repeats


def shorten(text: object, limit: int = ECHO_CHARS) -> str:
    """``text`` (or its ``str``) cut to ``limit`` characters with the number left out, for echoing a given value
    in a message without repeating a huge input."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text) - limit} more characters)"
