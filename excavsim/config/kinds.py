"""A kind of configuration file: what ``excavsim validate`` checks and how it tells a file's kind.

The platform's kinds (specifications, golden scenarios, campaigns, soils ...) and each task's own
(:attr:`excavsim.loop.plugin.TaskPlugin.config_kinds`) are :class:`ConfigKind` values; ``validate``
(:mod:`excavsim.validate`) gathers them and knows no kind by name.
"""

from __future__ import annotations

import dataclasses
import pathlib
from collections.abc import Callable

from pydantic import BaseModel


@dataclasses.dataclass(frozen=True)
class ConfigKind:
    """A kind of configuration file.

    Attributes:
        name: the kind's name (``validate --kind NAME``).
        model: returns the file's model, whose top-level fields tell a file's kind from its contents
            (a callable, so that a model of an upper layer is imported only when asked for).
        check: reads ``path`` with every check its use makes and says what it holds; raises
            :class:`~excavsim.errors.ConfigError` naming the file, the field and what is allowed.
        what: what such a file configures, in a few words (with its usual place).
        folders: the folders of ``configs/`` whose files are of this kind (``trenches`` holds goals);
            a folder of several kinds has its files told apart by their fields.
        stem: whether ``configs/<name>.yaml`` (and ``configs/<name>_*.yaml``, a variant) is of this kind.
        subfolders: whether the folders' subfolders (``trenches/<machine>/``) hold this kind too.
    """

    name: str
    model: Callable[[], type[BaseModel]]
    check: Callable[[pathlib.Path], str]
    what: str
    folders: tuple[str, ...] = ()
    stem: bool = False
    subfolders: bool = False


def plain_kind(name: str, model: type[BaseModel], what: str, **where) -> ConfigKind:
    """A kind whose check is its schema alone (the file loads into ``model``)."""
    from excavsim.config.loader import load_config

    def check(path: pathlib.Path) -> str:
        return load_config(path, model).__class__.__name__

    return ConfigKind(name, lambda: model, check, what, **where)
