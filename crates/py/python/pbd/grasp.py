"""Visual grasp prototypes (Sweeney 2011, ch. 6): record demonstrated grasps into a corpus, learn the
topic model of grasp prototypes (finite, or a Dirichlet process), generate pre-grasps for a seen
object (6.25)–(6.28), and the §6.5 evaluation against the naive hemisphere baseline.

Each function takes the options of the matching ``pbd grasp`` command as keyword arguments and returns a
:class:`pbd.Report` (a dict; ``str()`` is the summary). ``present={"scene": ..., "xy": [x, y],
"arm": "right"}`` says where objects are presented. One object of the evaluation at a time (for Ray):
:func:`pbd.experiment.grasp_trial`.
"""

from __future__ import annotations

import os
from typing import Any, Optional, Sequence

from . import _pbd
from ._util import Report, _options, _progress, _report

__all__ = ["record", "learn", "generate", "eval"]


def record(output: "os.PathLike[str] | str" = "corpus.json", *, objects: Optional[Sequence[str]] = None,
           progress: Any = None, **options: Any) -> Report:
    """Scripted grasp demonstrations on training presentations (``pbd grasp record``) → a corpus file.
    ``objects``: catalog presentations (default: all); ``demos`` per presentation; ``seed``."""
    opts = _options(output=output, objects=list(objects) if objects is not None else None, **options)
    return _report(_pbd.grasp_record(opts, _progress(progress)))


def learn(corpus: "os.PathLike[str] | str", output: "os.PathLike[str] | str" = "prototypes.json", *,
          progress: Any = None, **options: Any) -> Report:
    """Grasp prototypes from a corpus (``pbd grasp learn``): ``prototypes`` (A), ``nonparametric``,
    ``orientations`` (Q), ``burn_in``, ``chains``, ``seed``."""
    return _report(_pbd.grasp_learn(_options(corpus=corpus, output=output, **options), _progress(progress)))


def generate(model: "os.PathLike[str] | str", object: str, *, progress: Any = None, **options: Any) -> Report:
    """Pre-grasp candidates for a presented object from a prototype model (``pbd grasp generate``):
    ``n``, ``seed``, ``present``; ``mcap``: also draw the scene, the robot and the ranked pre-grasps
    (``/grasp/candidates``) into this MCAP file for Foxglove."""
    return _report(_pbd.grasp_generate(_options(model=model, object=object, **options), _progress(progress)))


def eval(output: "os.PathLike[str] | str" = "grasp-eval", *, progress: Any = None, **options: Any) -> Report:  # noqa: A001
    """The §6.5 experiment (``pbd grasp eval``): ``model`` or ``corpus`` (else record and learn here),
    ``test`` / ``objects``, ``candidates``, ``seed``, ``object_split`` (no presentation of a tested object
    trained on), ``naive_filtered`` (the naive baseline through the model's collision filter); writes the
    report files into ``output``, with the
    Fig. 6.7 plot ``fig6_7.svg`` (successes per test object, model against naive)."""
    return _report(_pbd.grasp_eval(_options(output=output, **options), _progress(progress)))
