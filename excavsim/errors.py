"""The package's exceptions: one tree under :class:`ExcavsimError`, so that a caller can catch by kind.

Messages say what was given, what is allowed, and where (the file, the field, the option)::

    ExcavsimError
    ├── ConfigError          a configuration file, option or argument value is invalid
    │   └── GoalError        a goal or pose the machine cannot reach, or outside the workspace
    ├── UsageError           options or calls that do not go together (an object used out of order)
    ├── ModelError           the MuJoCo model lacks an element, or is not shaped as the code assumes
    ├── WorldError           the simulated world cannot go on
    │   ├── Diverged         the physics became unstable
    │   └── OutOfTime        the episode's wall-clock limit passed
    ├── EnvError             a bad argument to an environment (also a ValueError)
    ├── SoilModelError       an input outside what a soil model allows (also a ValueError)
    │   └── WedgeError       ... of the static wedge model
    ├── DataFileError        a data file is missing, unreadable or malformed
    └── DependencyError      an optional extra or an outside program is missing

The ``excavsim`` command prints any of them as one message and exits with status 2.
"""


class ExcavsimError(Exception):
    """Base of every error excavsim raises on purpose; the CLI prints these without a traceback."""


class ConfigError(ExcavsimError):
    """A configuration file or value is invalid: the message names the file (or the option, or the
    argument), the field, what was given and what is allowed."""


class GoalError(ConfigError):
    """A goal, a target or a pose the machine cannot reach, or that lies outside the workspace."""


class UsageError(ExcavsimError):
    """Options or calls that do not go together: options that exclude or need each other, an object
    used out of order (a recorder used twice, a prediction before a fit), arrays of disagreeing shapes."""


class ModelError(ExcavsimError):
    """The MuJoCo model lacks an element the code needs, or is not shaped as the code assumes."""


class WorldError(ExcavsimError):
    """The simulated world cannot go on with the episode."""


class Diverged(WorldError):
    """The physics became unstable (a MuJoCo warning, an automatic reset, or a non-finite state): the
    world refuses every later step, and the dig that saw it ends with outcome ``diverged``."""


class OutOfTime(WorldError):
    """The episode's wall-clock limit passed while stepping: the dig and the episode end as ``timeout``."""


class EnvError(ExcavsimError, ValueError):
    """A bad argument to an environment: an action outside its space or not finite, a bad seed or
    option, a step before ``reset`` or after the episode ended."""


class SoilModelError(ExcavsimError, ValueError):
    """An input outside what a soil model allows (angles, lengths, speeds, heights); the message says
    which. Also a ValueError, as these models' input checks were."""


class WedgeError(SoilModelError):
    """An argument of the wedge model is outside what the model allows; the message says which."""


class DataFileError(ExcavsimError):
    """A data file (a force record, a recording, a saved map, a demonstration, a baseline) is missing,
    unreadable, unwritable or malformed: the message names the file and what is missing or wrong."""


class DependencyError(ExcavsimError):
    """An optional extra (``pip install 'excavsim[...]'``) or an outside program (git, the Rerun
    viewer) is missing or cannot start: the message says what to install."""


ECHO_CHARS = 80  # longest given value a message repeats


def shorten(text: object, limit: int = ECHO_CHARS) -> str:
    """``text`` (or its ``str``) cut to ``limit`` characters with the number left out, for echoing a given value
    in a message without repeating a huge input."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text) - limit} more characters)"
