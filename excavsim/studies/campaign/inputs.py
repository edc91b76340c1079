"""What a campaign's episodes read from disk, and a digest of it, so that one campaign is one version.

A campaign worker imports the package once, but every episode reads the machine's MuJoCo model
(``models/<machine>/*.xml``, compiled anew per world) and the configurations (``configs/*.yaml``) from
the working tree again, and imports some modules only when it first needs them. A checkout or a
merge in that tree while a campaign runs therefore changes the episodes that follow it, with the
code the worker loaded before: a mix that no commit holds. Measured: the truck-loading campaign of
2026-12-02 17:12 (``configs/campaigns/excavator_truck.yaml``, one worker) had heavy clay seed 0's
tuned and untuned runs differ from their first pass, as if the worker carried state from one episode
to the next; a merge at 17:21-17:22 had changed the 25 t excavator's linkage armature (13.6 ->
136.5) in ``models/excavator_25t/excavator_25t.xml`` between those two episodes. In one process with
that campaign's code, the episode gives pass 1 dig 6.36 s / script 14.10 s / peak stick 32.69 MPa
with the old file, 9.80 s / 14.58 s / 34.30 MPa with the new one (the untuned run's numbers), and the
first numbers again with the old file back.

:func:`digest` hashes every such file (:func:`default_roots`); the campaign takes it when it starts,
each worker checks it before and after each episode (:func:`changed`), and each result carries
:func:`combined` of it, so that a resumed campaign can tell the results made with other inputs.
"""

from __future__ import annotations

import hashlib
import pathlib
from collections.abc import Iterable

from excavsim import constants

Roots = Iterable[tuple[pathlib.Path, tuple[str, ...]]]


def default_roots() -> list[tuple[pathlib.Path, tuple[str, ...]]]:
    """The directories an episode reads and the glob patterns of its files there: the package's Python
    sources, the machines' models, and the configurations an episode loads (the top-level YAML files and
    the named trench goals; not the campaigns', specs', experiments' or regression files, which a
    campaign resolves before it starts or never reads)."""
    return [(constants.PACKAGE_ROOT, ("**/*.py",)),
            (constants.MODELS_DIR, ("**/*.xml", "**/*.stl", "**/*.obj", "**/*.png", "**/*.json")),
            (constants.CONFIGS_DIR, ("*.yaml", "trenches/**/*.yaml"))]


def _name(path: pathlib.Path, root: pathlib.Path) -> str:
    try:
        return path.relative_to(constants.REPO_ROOT).as_posix()
    except ValueError:
        return f"{root.name}/{path.relative_to(root).as_posix()}"


def digest(roots: Roots | None = None) -> dict[str, str]:
    """The SHA-256 of every input file (:func:`default_roots` unless ``roots`` is given), by its path
    relative to the repository (``models/excavator_25t/excavator_25t.xml``)."""
    out: dict[str, str] = {}
    for root, patterns in (default_roots() if roots is None else roots):
        for pattern in patterns:
            for path in root.glob(pattern):
                if path.is_file() and "__pycache__" not in path.parts:
                    out[_name(path, root)] = hashlib.sha256(path.read_bytes()).hexdigest()
    return dict(sorted(out.items()))


def combined(files: dict[str, str]) -> str:
    """One short hash of a :func:`digest` (what a result records)."""
    h = hashlib.sha256()
    for name, sha in sorted(files.items()):
        h.update(f"{name}\0{sha}\n".encode())
    return h.hexdigest()[:16]


def changed(before: dict[str, str], after: dict[str, str]) -> list[str]:
    """The files added, removed or changed from ``before`` to ``after`` (sorted)."""
    return sorted(n for n in before.keys() | after.keys() if before.get(n) != after.get(n))


def describe(files: list[str], limit: int = 5) -> str:
    """``files`` for a message: the first ``limit`` and how many more."""
    more = f" and {len(files) - limit} more" if len(files) > limit else ""
    return ", ".join(files[:limit]) + more
