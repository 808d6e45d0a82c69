"""Type stubs of the pbd package (the compiled classes live in pbd._pbd)."""

import os
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import bayes as bayes
from . import experiment as experiment
from . import grasp as grasp

__version__: str

PathLike = Union[str, os.PathLike[str]]
ArrayLike = Union[npt.NDArray[np.floating[Any]], npt.NDArray[np.integer[Any]], Sequence[float]]
ProgressCallback = Callable[[str, str, Optional[int]], None]
Progress = Union[bool, ProgressCallback, None]

class PbdError(Exception):
    """Every error raised by pbd; the message is the Rust error and its causes joined by ': '."""

class PbdValueError(PbdError, ValueError):
    """A wrong size, NaN or infinity, a parameter out of range."""

class PbdFormatError(PbdValueError):
    """A malformed input file or document (URDF, MCAP, JSON, TOML)."""

class PbdLookupError(PbdError, LookupError):
    """An unknown link, joint, scene, object, place or schema."""

class PbdFileError(PbdError, OSError):
    """A file that cannot be read or written."""

class PbdSimError(PbdError, RuntimeError):
    """The simulation, a skill or an experiment failed."""

class Robot:
    """A robot model loaded from a URDF (None: the built-in Dexter)."""

    @staticmethod
    def from_urdf(path: Optional[PathLike] = None) -> Robot: ...
    @staticmethod
    def from_urdf_string(text: str) -> Robot: ...
    @property
    def name(self) -> str: ...
    @property
    def source(self) -> str: ...
    @property
    def links(self) -> List[str]: ...
    @property
    def dofs(self) -> List[str]: ...
    def info(self) -> Dict[str, Any]: ...
    def chain(self, base: str, tip: str) -> Chain: ...

class Chain:
    """A serial chain base → tip: FK (4×4 base_from_tip), the geometric Jacobian (6×n, rows vx vy vz
    ωx ωy ωz in base axes; the J of Δu = −κ J† Δφ (3.4)) and IK."""

    @property
    def dof(self) -> int: ...
    @property
    def base(self) -> str: ...
    @property
    def tip(self) -> str: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def joint_kinds(self) -> List[str]: ...
    @property
    def lower(self) -> npt.NDArray[np.float64]: ...
    @property
    def upper(self) -> npt.NDArray[np.float64]: ...
    def fk(self, q: ArrayLike) -> npt.NDArray[np.float64]: ...
    def jacobian(self, q: ArrayLike) -> npt.NDArray[np.float64]: ...
    def fk_jacobian(self, q: ArrayLike) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def ik(
        self,
        target: npt.NDArray[np.float64],
        q0: Optional[ArrayLike] = None,
        *,
        position_tolerance: float = 1e-5,
        orientation_tolerance: float = 1e-4,
        max_iterations: int = 300,
        restarts: int = 100,
        seed: int = 0,
    ) -> Dict[str, Any]: ...
    def __len__(self) -> int: ...

class Demonstration:
    """A recorded demonstration (MCAP of pbd.record)."""

    @staticmethod
    def open(path: PathLike) -> Demonstration: ...
    @property
    def path(self) -> str: ...
    @property
    def metadata(self) -> Dict[str, str]: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def times(self) -> npt.NDArray[np.float64]: ...
    @property
    def percepts(self) -> List[Dict[str, Any]]: ...
    @property
    def truth(self) -> List[Any]: ...
    @property
    def topics(self) -> Dict[str, int]: ...
    def messages(self, topic: str) -> Tuple[npt.NDArray[np.float64], List[Any]]: ...
    def __len__(self) -> int: ...

class ProceduralModel:
    """The Bayesian procedural model (ch. 5): which features decide the place; ψ (5.14), ln B₁₀ (5.19)."""

    report: Optional[Report]
    def __init__(self, *, relevance_threshold: Optional[float] = None) -> None: ...
    @staticmethod
    def load(path: PathLike) -> ProceduralModel: ...
    @staticmethod
    def from_json(text: str) -> ProceduralModel: ...
    @staticmethod
    def learn(
        demos: Sequence[Union[PathLike, Dict[str, Any]]], *, relevance_threshold: Optional[float] = None
    ) -> ProceduralModel: ...
    def update(self, demo: Union[PathLike, Dict[str, Any]]) -> int: ...
    def predict(self, features: Dict[str, Any]) -> Dict[str, Any]: ...
    def explain(self) -> str: ...
    def explanation(self) -> Dict[str, Any]: ...
    def save(self, path: PathLike) -> None: ...
    def to_json(self) -> str: ...
    @property
    def places(self) -> List[str]: ...
    @property
    def num_demonstrations(self) -> int: ...

class Report(Dict[str, Any]):
    """A pipeline's report: the --json dict; str() is the human summary."""

    text: str
    warnings: List[str]
    def __init__(self, data: Dict[str, Any], text: str, warnings: List[str]) -> None: ...

class TextProgress:
    def __init__(self, file: Any = None) -> None: ...
    def __call__(self, event: str, text: str, value: Optional[int]) -> None: ...

def set_threads(n: int) -> None: ...
def record(
    output: PathLike = "demo.mcap",
    *,
    scene: Optional[str] = None,
    script: Optional[str] = None,
    seed: Optional[int] = None,
    progress: Progress = None,
    **options: Any,
) -> Report: ...
def infer(
    demo: Union[PathLike, Demonstration],
    *,
    output: Optional[PathLike] = None,
    library: Optional[PathLike] = None,
    progress: Progress = None,
) -> Report: ...
def learn(
    demos: Iterable[Union[PathLike, Report]],
    *,
    output: PathLike = "model.json",
    update: Optional[PathLike] = None,
    relevance_threshold: Optional[float] = None,
    progress: Progress = None,
) -> ProceduralModel: ...
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
    progress: Progress = None,
) -> Report: ...
def demo(out: PathLike = "pbd-demo", *, seed: Optional[int] = None, progress: Progress = None) -> Report: ...
