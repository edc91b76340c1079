"""Linear bases for learning resistive forces (Singh 1995 §5.2.2, eqs. 12-17).

A basis turns the columns of a force sample (:mod:`excavsim.learning.encoding`) into the terms
``G_i`` of ``G_1 k_1 + ... + G_n k_n = F`` (eq. 12):

* naive (eq. 15): ``alpha, d_1, d_2, l_1..l_5, c_1..c_3``: the action and a compact geometric
  description of the terrain (elevations along the trench from the entry, fixed for a dig, and
  across it at the bucket);
* mechanics-based (eq. 16): ``rho, d_1, d_2, l_1^2..l_5^2, c_1^2..c_3^2, v``: the rake, depths
  of soil above and ahead of the tip squared (the wedge's weight term grows with depth squared,
  eq. 8), and the swept volume (the surcharge);
* reduced (eq. 17): ``rho, d_1, d_2, l_1^2, l_2^2, l_3^2, c_2^2, v``: the terms found to matter.

``d_1``, ``d_2`` are the distances moved along the penetration and the drag (Fig. 66): the columns
``s1``, ``s2``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from excavsim.errors import ConfigError, UsageError
from excavsim.learning.encoding import Samples


@dataclasses.dataclass(frozen=True)
class Basis:
    """A named set of terms, each a sample column raised to a power.

    Attributes:
        name: short name (``naive``, ``mechanics``, ``reduced``).
        equation: the thesis' equation number.
        terms: ``(column, power)`` per basis function.
        labels: printable names of the terms (as in Table 2).
    """

    name: str
    equation: str
    terms: tuple[tuple[str, int], ...]
    labels: tuple[str, ...]

    @property
    def size(self) -> int:
        """Number of basis functions D."""
        return len(self.terms)

    @property
    def columns(self) -> tuple[str, ...]:
        """The sample columns the basis reads."""
        return tuple(dict.fromkeys(c for c, _ in self.terms))

    def design(self, samples: Samples) -> np.ndarray:
        """The basis functions of every sample: (..., D) for columns of shape (...).

        Raises:
            ExcavsimError: a column the basis needs is missing.
        """
        missing = [c for c in self.columns if c not in samples]
        if missing:
            raise UsageError(f"the {self.name} basis (eq. {self.equation}) needs the columns {list(self.columns)}; "
                             f"missing {missing}")
        return np.stack([np.asarray(samples[c], dtype=float) ** p for c, p in self.terms], axis=-1)


def _terms(spec: str) -> tuple[tuple[tuple[str, int], ...], tuple[str, ...]]:
    """``"rake s1 l1^2"`` -> terms and labels."""
    names = {"alpha": "alpha", "rake": "rho", "s1": "d_1", "s2": "d_2", "v": "v"}
    terms, labels = [], []
    for word in spec.split():
        col, _, power = word.partition("^")
        p = int(power or 1)
        terms.append((col, p))
        base = names.get(col)
        if base is None:  # l1, c2, lz3, cz1
            letter = col.rstrip("0123456789").rstrip("z")
            base = f"{letter}_{col[len(col.rstrip('0123456789')):]}"
        labels.append(base + (f"^{p}" if p != 1 else ""))
    return tuple(terms), tuple(labels)


NAIVE = Basis("naive", "15", *_terms("alpha s1 s2 lz1 lz2 lz3 lz4 lz5 cz1 cz2 cz3"))
MECHANICS = Basis("mechanics", "16", *_terms("rake s1 s2 l1^2 l2^2 l3^2 l4^2 l5^2 c1^2 c2^2 c3^2 v"))
REDUCED = Basis("reduced", "17", *_terms("rake s1 s2 l1^2 l2^2 l3^2 c2^2 v"))
BASES = {b.name: b for b in (NAIVE, MECHANICS, REDUCED)}


def get_basis(name: str | Basis) -> Basis:
    """A basis by name (or the basis itself).

    Raises:
        ExcavsimError: an unknown name; the message lists the bases.
    """
    if isinstance(name, Basis):
        return name
    try:
        return BASES[name]
    except KeyError:
        raise ConfigError(f"unknown basis {name!r}; available: {', '.join(BASES)}") from None
