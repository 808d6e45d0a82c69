"""pbd — teleological robot programming by demonstration (Sweeney 2011), from Python.

The robot watches a teleoperated demonstration, infers *which of its own schemas the teacher
intended* (§4.2), learns from a few examples which object features decide the task's references
(ch. 5) and does the task in new scenes. Everything runs on the simulated Dexter (two WAM arms,
BarrettHands, a stereo head) or on any URDF for the kinematics.

>>> import pbd
>>> robot = pbd.Robot.from_urdf(None)          # the built-in Dexter
>>> arm = robot.chain("left/base_link", "left/wrist_palm_link")
>>> arm.fk([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7]).shape
(4, 4)

Pipelines: :func:`record` → :func:`infer` → :func:`learn` → :func:`execute` (:func:`demo` runs all
four). Statistics: :mod:`pbd.bayes`. Batches of trials, locally or on Ray: :mod:`pbd.experiment`.
Errors are :class:`PbdError` subclasses (also the builtin exception they resemble:
``PbdValueError`` is a ``ValueError``, ``PbdFileError`` an ``OSError``, ``PbdLookupError`` a
``LookupError``).
"""

from __future__ import annotations

import os
import tempfile
from typing import Any, Callable, Iterable, Optional, Union

from . import _pbd
from ._pbd import (
    Chain,
    ControlStack,
    Demonstration,
    PbdError,
    PbdFileError,
    PbdFormatError,
    PbdLookupError,
    PbdSimError,
    PbdValueError,
    ProceduralModel,
    Robot,
    Sim,
    set_threads,
)

__version__ = _pbd.__version__

PathLike = Union[str, "os.PathLike[str]"]
ProgressCallback = Callable[[str, str, Optional[int]], None]

from ._util import Report, TextProgress, _options, _progress, _report  # noqa: E402


def record(
    output: PathLike = "demo.mcap",
    *,
    scene: Optional[str] = None,
    script: Optional[str] = None,
    seed: Optional[int] = None,
    progress: Union[bool, ProgressCallback, None] = None,
    **options: Any,
) -> Report:
    """Records a teleoperated demonstration in the simulator (``pbd record``) into an MCAP file.

    ``script`` is the scripted teacher's task (``pick-place``, ``sort``, ``pick-hold``,
    ``hand-over``, ``touch``, ``wander``); other options as ``pbd record`` (``object``, ``place``,
    ``assign``, ``arm``, ``retry``, ``teleop``, ``images``, ``image_format``, ``percept_hz``,
    ``max_seconds``, …; ``encoding="ros2"`` writes CDR with ROS 2 message definitions, which
    ``ros2 bag`` and ``rosbags`` read).
    Ctrl-C finishes the file with what was captured and raises ``KeyboardInterrupt``.
    """
    opts = _options(output=output, scene=scene, script=script, seed=seed, **options)
    return _report(_pbd.record(opts, _progress(progress)))


def infer(
    demo: PathLike,
    *,
    output: Optional[PathLike] = None,
    library: Optional[PathLike] = None,
    progress: Union[bool, ProgressCallback, None] = None,
) -> Report:
    """Which schema explains a demonstration (``pbd infer``, §4.2): the posterior over the schema library
    and *none* (4.10)–(4.12), the MAP schema's Viterbi state path and the instances with their
    procedural facts. Writes ``NAME.infer.json`` (the report's ``file``) and ``NAME.infer.mcap``.

    ``report["file"]["inference"]["posterior"]["map"]`` is the MAP schema.
    """
    if isinstance(demo, Demonstration):
        demo = demo.path
    opts = _options(demo=demo, output=output, library=library)
    return _report(_pbd.infer(opts, _progress(progress)))


def learn(
    demos: Iterable[PathLike],
    *,
    output: PathLike = "model.json",
    update: Optional[PathLike] = None,
    relevance_threshold: Optional[float] = None,
    distractors: bool = True,
    progress: Union[bool, ProgressCallback, None] = None,
) -> ProceduralModel:
    """Learns the procedural model (``pbd learn``, ch. 5) from ``*.infer.json`` / ``*.mcap`` files (or
    updates the model file ``update``), saves it to ``output`` and returns it; ``model.report`` is the
    learn report (examples used, explanation). With ``distractors`` (the default) the relevance
    background model M₀ is fitted to the objects the teacher left alone in the demonstrations."""
    items = []
    for d in demos:
        if isinstance(d, dict) and "json_path" in d:  # a report of pbd.infer
            d = d["json_path"]
        items.append(os.fspath(d))
    opts = _options(demos=items, output=output, update=update, relevance_threshold=relevance_threshold,
                    distractors=distractors)
    report = _report(_pbd.learn(opts, _progress(progress)))
    model = ProceduralModel.load(os.fspath(output))
    model.report = report
    return model


def execute(
    model: Union[ProceduralModel, PathLike, None] = None,
    scene: str = "sorting-new",
    *,
    demo: Optional[PathLike] = None,
    object: Optional[str] = None,
    place: Optional[str] = None,
    library: Optional[PathLike] = None,
    seed: Optional[int] = None,
    output: Optional[PathLike] = None,
    calibration: Optional[PathLike] = None,
    progress: Union[bool, ProgressCallback, None] = None,
) -> Report:
    """The robot does the task of a procedural model (or of an inference, ``demo=``) in a scene
    (``pbd execute``, §4.3.2): per object the decision (place, ln B₁₀ (5.19)), the arms, the
    contingencies, and whether it ended in its place. ``output`` writes an MCAP log of the run;
    ``calibration`` loads the robot's calibration of the empty workcell from a file (``pbd calibrate``)
    instead of calibrating it first."""
    with tempfile.TemporaryDirectory(prefix="pbd-") as tmp:
        if isinstance(model, ProceduralModel):
            path = os.path.join(tmp, "model.json")
            model.save(path)
            model = path
        opts = _options(
            model=model, scene=scene, demo=demo, object=object, place=place, library=library, seed=seed,
            output=output, calibration=calibration,
        )
        return _report(_pbd.execute(opts, _progress(progress)))


def demo(
    out: PathLike = "pbd-demo",
    *,
    seed: Optional[int] = None,
    progress: Union[bool, ProgressCallback, None] = None,
) -> Report:
    """The whole story (``pbd demo``): record → infer → learn → execute on the built-in scenes; every
    file goes to ``out``."""
    return _report(_pbd.demo(_options(out=out, seed=seed), _progress(progress)))


def pick_place(
    *, scene: Optional[str] = None, progress: Union[bool, ProgressCallback, None] = None, **options: Any
) -> Report:
    """One autonomous pick-and-place in the simulator (``pbd sim pick-place``): Search-Track (§3.2.2.1),
    Reach (3.17), Grasp, Lift and weigh, Transport and Place (§3.3.3). Options as the command
    (``object``, ``place``, ``arm``, ``seed``, ``mcap``)."""
    return _report(_pbd.pick_place(_options(scene=scene, **options), _progress(progress)))


from . import bayes, experiment, grasp  # noqa: E402  (they import the names above)

__all__ = [
    "Chain",
    "ControlStack",
    "Demonstration",
    "PbdError",
    "PbdFileError",
    "PbdFormatError",
    "PbdLookupError",
    "PbdSimError",
    "PbdValueError",
    "ProceduralModel",
    "Report",
    "Robot",
    "Sim",
    "TextProgress",
    "bayes",
    "demo",
    "execute",
    "experiment",
    "grasp",
    "infer",
    "learn",
    "pick_place",
    "record",
    "set_threads",
]
