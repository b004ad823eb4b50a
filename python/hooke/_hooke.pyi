from typing import Any, Callable, List, Optional, Tuple

import numpy as np

__version__: str

class CaseError(ValueError): ...
class RunError(RuntimeError): ...

class Simulation:
    time: float
    steps: int
    end_time: float
    dt: Optional[float]
    nodes: int
    springs: int
    out: str
    positions: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    damage: np.ndarray
    spring_ends: np.ndarray
    spring_intact: np.ndarray
    def step(self, n: int = 1) -> None: ...
    def run(self, until: Optional[float] = None, every: Optional[float] = None,
            callback: Optional[Callable[[Any], Any]] = None) -> None: ...
    def finish(self) -> str: ...
    def energy_json(self) -> str: ...
    def reactions_json(self) -> str: ...
    def broken(self) -> Tuple[int, float]: ...

def load_case(path: str, text: str, out: str, name: str, set: List[str] = ..., scale: float = 1.0,
              command: List[str] = ...) -> Simulation: ...
def moduli_json(flags: List[str]) -> str: ...
