"""Experiments as independent trials, run locally or fanned out on Ray.

A **trial** is a pure function of ``(config, trial index)`` → result dict: the seed lives in the
config and every random choice of the trial comes from the seeded stream ``(seed, trial)``
(``bayes::rng``), so any scheduler gives the same result for the same trial, on any machine.

>>> config = {"model": "pbd-demo/model.json", "scene": "sorting-new", "objects": 4,
...           "task": {"red": "bin_right", "blue": "bin_left"}, "seed": 0}
>>> local = pbd.experiment.run(config, 8)                  # one after the other, in this process
>>> remote = pbd.experiment.run(config, 8, backend="ray")  # one Ray task per trial
>>> [strip(r) for r in local] == [strip(r) for r in remote]   # strip = drop "wall_time"
True

Kinds of trial (``kind=``):

- ``"execute"`` (:func:`execute_trial`): random scene ``trial`` drawn from the base scene's catalog
  and the robot's execution of the model's task in it (``pbd experiment execute``, one scene).
- ``"grasp"`` (:func:`grasp_trial`): test object ``trial`` of the grasp evaluation (§6.5), every
  candidate of the prototype model and of the naive baseline executed (``pbd grasp eval``, one
  object); ``trials=None`` runs every test object.
- ``"sorting"`` (:func:`sorting_trial`): trial ``trial`` of the sorting or relevance experiment of
  §5.1–5.3 (``pbd experiment sorting``): a procedural model learned from ``examples`` examples per
  class, the held-out objects sorted (or scored by ln B₁₀ (5.19) for relevance).
- ``"perception"`` (:func:`perception_trial`): random scene ``trial`` of the execute experiment
  looked over by the robot and compared with the truth (``pbd experiment perception``, one scene).
"""

from __future__ import annotations

import os
import sys
import tempfile
from typing import Any, Callable, Dict, Iterable, List, Optional, Union

from . import _pbd
from ._util import Report, _options, _progress, _report

__all__ = ["execute_trial", "grasp_trial", "sorting_trial", "sorting", "perception_trial", "perception",
           "grasp_objects", "run", "trial", "strip_timing", "KINDS"]


def _materialize(config: Dict[str, Any], tmp: str) -> Dict[str, Any]:
    """Writes an inlined model (``model_json``) to a file, so trials run on any node of a cluster."""
    config = dict(config)
    text = config.pop("model_json", None)
    if text is not None:
        path = os.path.join(tmp, "model.json")
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        config["model"] = path
    return config


def execute_trial(config: Dict[str, Any], trial: int) -> Dict[str, Any]:
    """One trial of the execute experiment (a pure function of ``(config, trial)``).

    ``config``: ``model`` (path of ``model.json``, or ``model_json`` with its text, or a
    :class:`pbd.ProceduralModel`), ``scene`` (base scene, default ``sorting-new``), ``objects`` per
    scene (4), ``task`` (colour class → place, for scoring), ``seed`` (0). Returns ``trial``,
    ``seed``, ``rows`` (one per object: decision, place, ln B₁₀ (5.19), arms, transfer, placed, …),
    ``summary``, ``report`` and ``wall_time`` (the only field that differs between runs).
    """
    config = dict(config)
    model = config.get("model")
    if model is not None and not isinstance(model, (str, os.PathLike)):
        config.pop("model")
        config["model_json"] = model.to_json()
    with tempfile.TemporaryDirectory(prefix="pbd-trial-") as tmp:
        return _pbd.experiment.execute_trial(_materialize(config, tmp), int(trial))


def grasp_objects(config: Dict[str, Any]) -> List[str]:
    """The test presentations of the grasp experiment in trial order (``objects``, or the first ``test``
    catalog presentations in the seed's order that the model was not trained on)."""
    with tempfile.TemporaryDirectory(prefix="pbd-trial-") as tmp:
        return _pbd.experiment.grasp_objects(_materialize(_inline_model(config), tmp))


def grasp_trial(config: Dict[str, Any], trial: int) -> Dict[str, Any]:
    """One trial of the grasp experiment (§6.5), a pure function of ``(config, trial)``: test
    presentation ``trial`` perceived, ``candidates`` pre-grasps from the prototype model and from the
    naive baseline, each executed in the sim (reach, close, lift 10 cm, still held?).

    ``config``: ``model`` (prototypes JSON from :func:`pbd.grasp.learn`, or ``model_json``),
    ``present`` (``{"scene", "xy", "arm"}``), ``seed``, ``candidates`` (6), ``objects`` or ``test``
    (12) — the options of ``pbd grasp eval``. Returns ``{trial, object, result: {object, trials}}``,
    the rows ``pbd grasp eval`` reports for that object.
    """
    with tempfile.TemporaryDirectory(prefix="pbd-trial-") as tmp:
        return _pbd.experiment.grasp_trial(_materialize(_inline_model(config), tmp), int(trial))


def sorting_trial(config: Dict[str, Any], trial: int) -> Dict[str, Any]:
    """One trial of the sorting or relevance experiment (§5.1–5.3), a pure function of
    ``(config, trial)``: ``examples`` examples per class drawn by the seeded stream of the trial, a
    procedural model learned from them (Eqs. 5.1–5.18), the held-out objects sorted by the MAP place,
    or scored by the Bayes factor ln B₁₀ (5.19) against the other objects for ``relevance``.

    ``config``: ``feature`` (``color`` | ``size`` | ``relevance``), ``classes`` (default red, blue /
    small, large), ``examples`` (per class, 1), ``seed`` (1), ``views`` (4), ``structure``, and
    ``catalog`` (TOML path; default the built-in household catalog — rendered once per process) or
    ``features`` (a bank written by ``pbd experiment sorting --dump-features``); optional
    ``test_catalog`` / ``test_features``, ``background``, ``uniform_base`` (colour base measure uniform
    over the colour terms), ``neighbour_share`` (ε given to each neighbouring colour term) and
    ``chromatic_share`` (the chromatic rule's share, default 0.5). Returns the trial's
    row of the experiment's CSV: ``correct``, ``tested``, ``success_rate``, ``chi2_p_value`` (``None``
    with ``chi2_not_computed`` saying why when the test cannot be computed), ``map_structure``,
    ``map_structure_probability``, and for relevance ``auc`` and ``accuracy_at_threshold``.
    """
    config = dict(config)
    if config.get("features") is not None:
        config["features"] = os.fspath(config["features"])
    if config.get("catalog") is not None:
        config["catalog"] = os.fspath(config["catalog"])
    return _pbd.experiment.sorting_trial(config, int(trial))


def sorting(output: "os.PathLike[str] | str" = "experiment-sorting", *, progress: Any = None,
            **options: Any) -> Report:
    """The whole sorting experiment (``pbd experiment sorting``): ``feature`` (``color`` | ``size`` |
    ``relevance`` | ``incremental`` | ``selection``), ``classes``, ``trials``, ``max_examples``,
    ``structure``, ``views``, ``seed``, ``catalog`` or ``features`` (a feature bank), ``dump_features``,
    ``test_catalog`` / ``test_features``, ``background``, ``uniform_base``, ``neighbour_share``,
    ``chromatic_share``.
    Writes the CSVs, ``summary.md`` and the SVG figures into ``output``; returns the summary
    (``rows`` per class set and number of examples, ``notes``, ``files``). One trial of it:
    :func:`sorting_trial`."""
    return _report(_pbd.experiment_sorting(_options(output=output, **options), _progress(progress)))


def perception_trial(config: Dict[str, Any], trial: int) -> Dict[str, Any]:
    """One trial of the perception experiment, a pure function of ``(config, trial)``: random scene
    ``trial`` — the execute experiment's scene with the same seed — looked over by the robot (its
    honest eyes: calibration backgrounds and its own self-model) and compared with the truth.

    ``config``: ``scene`` (base scene, default ``sorting-demo``), ``objects`` per scene (3), ``seed``
    (1). Returns ``trial``, ``seed``, ``objects`` (per object: ``object``, ``segments`` — 0 missed, 2
    or more duplicates — ``centroid_error_xy``, ``centroid_error_z``, ``height_error``,
    ``footprint_error``, in metres, ``None`` when missed) and ``phantoms`` (segments on the table that
    match no object).
    """
    config = dict(config)
    if config.get("scene") is not None:
        config["scene"] = os.fspath(config["scene"])
    return _pbd.experiment.perception_trial(config, int(trial))


def perception(output: "os.PathLike[str] | str" = "experiment-perception", *, progress: Any = None,
               **options: Any) -> Report:
    """The whole perception experiment (``pbd experiment perception``): ``scene``, ``scenes`` (50),
    ``objects`` (3), ``seed`` (1). Writes ``objects.csv``, ``summary.md`` and ``errors.svg`` into
    ``output``; returns the summary (``objects``, ``missed``, ``duplicates``, ``phantoms``, and the
    median / max of the centroid, height and footprint errors). One scene of it:
    :func:`perception_trial`."""
    return _report(_pbd.experiment_perception(_options(output=output, **options), _progress(progress)))


def _inline_model(config: Dict[str, Any]) -> Dict[str, Any]:
    config = dict(config)
    model = config.get("model")
    if model is not None and not isinstance(model, (str, os.PathLike)):
        config.pop("model")
        config["model_json"] = model.to_json()
    return config


KINDS: Dict[str, Callable[[Dict[str, Any], int], Dict[str, Any]]] = {
    "execute": execute_trial,
    "grasp": grasp_trial,
    "sorting": sorting_trial,
    "perception": perception_trial,
}


def trial(kind: str, config: Dict[str, Any], index: int) -> Dict[str, Any]:
    """Runs trial ``index`` of experiment ``kind`` (see :data:`KINDS`)."""
    try:
        f = KINDS[kind]
    except KeyError:
        raise _pbd.PbdLookupError(f"unknown experiment kind {kind!r}; known: {', '.join(KINDS)}") from None
    return f(config, index)


def strip_timing(result: Any) -> Any:
    """The result without its wall-time fields (for comparing runs)."""
    if isinstance(result, dict):
        return {k: strip_timing(v) for k, v in result.items() if k != "wall_time"}
    if isinstance(result, list):
        return [strip_timing(v) for v in result]
    return result


class _Bar:
    def __init__(self, total: int, desc: str, enabled: bool):
        self.bar = None
        self.enabled = enabled
        self.total = total
        self.done = 0
        self.desc = desc
        if enabled:
            try:
                from tqdm.auto import tqdm  # type: ignore

                self.bar = tqdm(total=total, desc=desc, file=sys.stderr)
            except ImportError:
                pass

    def update(self) -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.update(1)
        elif self.enabled:
            print(f"\r{self.desc}: {self.done}/{self.total}", end="", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.enabled:
            print(file=sys.stderr)


def _ray_trial(kind: str, config: Dict[str, Any], index: int) -> Dict[str, Any]:
    # Runs in a Ray worker process: one trial, single-threaded pool (Ray schedules the CPUs).
    os.environ.setdefault("RAYON_NUM_THREADS", "1")
    return trial(kind, config, index)


def run(
    config: Dict[str, Any],
    trials: Union[int, Iterable[int], None] = None,
    backend: str = "local",
    *,
    kind: str = "execute",
    progress: bool = True,
    address: Optional[str] = None,
    num_cpus_per_trial: float = 1,
) -> List[Dict[str, Any]]:
    """Runs trials ``0..trials-1`` (or the given indices) of an experiment and returns their result
    dicts in trial order.

    ``backend="local"`` runs them one after the other in this process; ``backend="ray"`` submits one
    Ray task per trial (``ray.init(address=address)`` if Ray is not initialised yet: ``None`` starts a
    local Ray, ``"auto"`` joins the cluster this machine belongs to) and gathers them as they finish,
    with a progress bar. Results are identical trial by trial whatever the backend (except
    ``wall_time``); the model is sent inline to the workers, so they need pbd installed but no shared
    files.
    """
    if kind not in KINDS:
        raise _pbd.PbdLookupError(f"unknown experiment kind {kind!r}; known: {', '.join(KINDS)}")
    config = dict(config)
    model = config.get("model")
    if model is not None:
        config.pop("model")
        if isinstance(model, (str, os.PathLike)):
            try:
                with open(model, encoding="utf-8") as f:
                    config["model_json"] = f.read()
            except OSError as e:
                raise _pbd.PbdFileError(f"cannot read model {os.fspath(model)}: {e}") from None
        else:
            config["model_json"] = model.to_json()
    if trials is None:
        if kind != "grasp":
            raise _pbd.PbdValueError("trials: give the number of trials (or their indices)")
        trials = len(grasp_objects(config))
    indices = list(range(trials)) if isinstance(trials, int) else [int(i) for i in trials]
    bar = _Bar(len(indices), f"{kind} trials ({backend})", progress)
    try:
        if backend == "local":
            out = []
            for i in indices:
                out.append(trial(kind, config, i))
                bar.update()
            return out
        if backend == "ray":
            try:
                import ray  # type: ignore
            except ImportError:
                raise _pbd.PbdValueError('backend="ray" needs Ray: pip install "ray>=2.40"') from None
            if not ray.is_initialized():
                ray.init(address=address, include_dashboard=False, log_to_driver=False)
            remote = ray.remote(num_cpus=num_cpus_per_trial, max_retries=0)(_ray_trial)
            config_ref = ray.put(config)
            refs = {remote.remote(kind, config_ref, i): k for k, i in enumerate(indices)}
            results: List[Any] = [None] * len(indices)
            pending = list(refs)
            try:
                while pending:
                    done, pending = ray.wait(pending, num_returns=1, timeout=0.5)
                    for ref in done:
                        results[refs[ref]] = ray.get(ref)
                        bar.update()
            except BaseException:
                for ref in pending:
                    ray.cancel(ref, force=True)
                raise
            return results
        raise _pbd.PbdValueError(f'backend must be "local" or "ray", got {backend!r}')
    finally:
        bar.close()
