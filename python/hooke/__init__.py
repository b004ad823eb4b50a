"""hooke from Python: script, run and inspect mass-spring lattice simulations of elastic solids
and their fracture, at any Poisson's ratio (the momentum dispersion of Kot & Nagahashi).

    import hooke
    sim = hooke.load_case("cases/mode1_plate.toml", scale=0.25, set={"solver.end_time": 20e-6})
    sim.run(every=5e-6, callback=lambda s: print(s.time, s.broken()))
    print(sim.energy()["kinetic"], sim.reactions())
    summary = sim.finish()
    frames = hooke.read(summary["output_dir"])

The stepping, the physics and the files are hooke's own (the Rust library behind the command
line), so a case run here writes exactly what ``hooke run`` writes.
"""
from __future__ import annotations

import json
import os
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _hooke
from ._hooke import CaseError, RunError

__version__ = _hooke.__version__
__all__ = ["load_case", "loads", "Builder", "ramp", "smooth_ramp", "table", "Simulation", "moduli",
           "toughness", "read", "Output", "Reaction", "CaseError", "RunError",
           "Region", "All", "Face", "Plane", "Nodes", "Shape", "Box", "Sphere", "Cylinder",
           "Capsule", "HalfSpace", "Report", "Moduli", "Toughness", "Check", "Summary"]


def _vec(v: Any, what: str) -> List[float]:
    """A point or vector as a list of floats (2 or 3 of them)."""
    try:
        out = [float(x) for x in v]
    except (TypeError, ValueError):
        raise CaseError(f"{what}: give 2 or 3 numbers, not {v!r}") from None
    if len(out) not in (2, 3):
        raise CaseError(f"{what}: give 2 or 3 numbers, not {len(out)}")
    return out


class Region:
    """Where conditions act: a set of nodes. ``All()``, ``Face("y+")``, ``Plane("x", 0.0)``,
    ``Nodes([...])``, or any :class:`Shape` (the nodes inside it). Builder methods also take
    the older forms: ``"all"`` and dicts such as ``{"face": "y+"}``."""

    def _region(self) -> Any:
        raise NotImplementedError

    def __eq__(self, other: Any) -> bool:
        return isinstance(other, Region) and self._region() == other._region()

    def __repr__(self) -> str:
        return f"hooke.{type(self).__name__}({self._region()!r})"


class All(Region):
    """Every node of the body."""

    def _region(self) -> Any:
        return "all"


class Face(Region):
    """The nodes on a face of the body's bounding box: ``"x-"``, ``"x+"``, ``"y-"``, ``"y+"``,
    ``"z-"`` or ``"z+"``."""

    def __init__(self, face: str):
        if face not in ("x-", "x+", "y-", "y+", "z-", "z+"):
            raise CaseError(f"Face({face!r}): give x-, x+, y-, y+, z- or z+")
        self.face = face

    def _region(self) -> Any:
        return {"face": self.face}


class Plane(Region):
    """The nodes on the plane ``axis = at`` (m), within ``tolerance`` (m; default: a fraction
    of the spacing)."""

    def __init__(self, axis: str, at: float, tolerance: Optional[float] = None):
        if axis not in ("x", "y", "z"):
            raise CaseError(f"Plane(axis={axis!r}): give x, y or z")
        self.axis, self.at, self.tolerance = axis, float(at), tolerance

    def _region(self) -> Any:
        p: Dict[str, Any] = {"axis": self.axis, "at": self.at}
        if self.tolerance is not None:
            p["tolerance"] = float(self.tolerance)
        return {"plane": p}


class Nodes(Region):
    """These nodes, by index."""

    def __init__(self, nodes: Any):
        self.nodes = [int(n) for n in np.asarray(nodes).ravel()]

    def _region(self) -> Any:
        return {"nodes": self.nodes}


class Shape(Region):
    """A solid: it makes up a body (``Builder.add``, ``Builder.subtract``), selects the nodes
    inside it as a region, and is a rigid body's shape (``Builder.rigid``, placed at its
    centre unless a position is given)."""

    def _shape(self) -> Any:
        raise CaseError(f"{type(self).__name__} cannot make up a lattice body; use Box, Sphere or Cylinder")

    def _rigid(self) -> Tuple[Dict[str, Any], Optional[List[float]]]:
        raise NotImplementedError

    def _region(self) -> Any:
        return {"inside": self._shape()}


class Box(Shape):
    """The axis-aligned box from ``min`` to ``max`` (m)."""

    def __init__(self, min: Any, max: Any):
        self.min, self.max = _vec(min, "Box min"), _vec(max, "Box max")
        if len(self.min) != len(self.max):
            raise CaseError("Box: give min and max with as many coordinates")

    def _shape(self) -> Any:
        return {"box": {"min": self.min, "max": self.max}}

    def _region(self) -> Any:
        return {"box": {"min": self.min, "max": self.max}}

    def _rigid(self) -> Tuple[Dict[str, Any], Optional[List[float]]]:
        size = [b - a for a, b in zip(self.min, self.max)]
        centre = [(a + b) / 2 for a, b in zip(self.min, self.max)]
        return {"box": {"size": size}}, centre


class Sphere(Shape):
    """The ball (a disk in 2D) of ``radius`` (m) about ``center``."""

    def __init__(self, center: Any, radius: float):
        self.center, self.radius = _vec(center, "Sphere center"), float(radius)

    def _shape(self) -> Any:
        return {"sphere": {"center": self.center, "radius": self.radius}}

    def _rigid(self) -> Tuple[Dict[str, Any], Optional[List[float]]]:
        return {"sphere": {"radius": self.radius}}, self.center


class Cylinder(Shape):
    """The cylinder of ``radius`` and ``length`` (m) about ``center``, along ``axis`` (x, y or
    z)."""

    def __init__(self, center: Any, axis: str, radius: float, length: float):
        if axis not in ("x", "y", "z"):
            raise CaseError(f"Cylinder(axis={axis!r}): give x, y or z")
        self.center, self.axis = _vec(center, "Cylinder center"), axis
        self.radius, self.length = float(radius), float(length)

    def _shape(self) -> Any:
        return {"cylinder": {"center": self.center, "axis": self.axis, "radius": self.radius,
                             "length": self.length}}

    def _rigid(self) -> Tuple[Dict[str, Any], Optional[List[float]]]:
        return ({"cylinder": {"radius": self.radius, "length": self.length, "axis": self.axis}},
                self.center)


class Capsule(Shape):
    """A rigid capsule: a cylinder of ``radius`` and ``length`` (m) along ``axis`` with
    hemispherical ends, about ``center``. A rigid body's shape only."""

    def __init__(self, center: Any, axis: str, radius: float, length: float):
        if axis not in ("x", "y", "z"):
            raise CaseError(f"Capsule(axis={axis!r}): give x, y or z")
        self.center, self.axis = _vec(center, "Capsule center"), axis
        self.radius, self.length = float(radius), float(length)

    def _rigid(self) -> Tuple[Dict[str, Any], Optional[List[float]]]:
        return ({"capsule": {"radius": self.radius, "length": self.length, "axis": self.axis}},
                self.center)


class HalfSpace(Shape):
    """A rigid half-space: everything behind the plane through ``point`` with outward
    ``normal``. A rigid body's shape only."""

    def __init__(self, point: Any, normal: Any):
        self.point, self.normal = _vec(point, "HalfSpace point"), _vec(normal, "HalfSpace normal")

    def _rigid(self) -> Tuple[Dict[str, Any], Optional[List[float]]]:
        return {"halfspace": {"normal": self.normal}}, self.point


def _region(r: Any) -> Any:
    """A region as the builder's spec: a :class:`Region`, or the older string and dict forms."""
    return r._region() if isinstance(r, Region) else r


def _shape(s: Any) -> Any:
    """A body shape as the builder's spec: a :class:`Shape`, or the older dict form."""
    return s._shape() if isinstance(s, Shape) else s


class Reaction:
    """One boundary region's reaction now: its ``name``, ``force`` on the body (N; in 2D for
    the plate's thickness) and mean ``displacement`` (m), each a numpy array of 3. Indexing by
    key (``r["force"]``) reads the same fields, as the dicts these replace did."""

    __slots__ = ("name", "force", "displacement")

    def __init__(self, name: str, force: Any, displacement: Any):
        self.name = name
        self.force = np.asarray(force, dtype=float)
        self.displacement = np.asarray(displacement, dtype=float)

    def __getitem__(self, key: str) -> Any:
        if key not in self.__slots__:
            raise KeyError(key)
        return getattr(self, key)

    def keys(self) -> List[str]:
        return list(self.__slots__)

    def __repr__(self) -> str:
        return (f"hooke.Reaction({self.name!r}, force={self.force.tolist()}, "
                f"displacement={self.displacement.tolist()})")


class Report(dict):
    """A measurement's or a run's report, as the command line's ``--json`` writes it: every
    key reads as an attribute too (``r.nu_measured``), where a list of numbers comes back as a
    numpy array (``r.C_measured`` is 6x6) and a nested report as a :class:`Report`. It is
    still the JSON's mapping (``r["nu_measured"]``, comparisons, ``json.dumps``), so the keys
    stay the command line's, a contract with other tools."""

    __slots__ = ()

    def __getattr__(self, key: str) -> Any:
        try:
            value = self[key]
        except KeyError:
            raise AttributeError(f"{type(self).__name__} has no {key!r}; its keys: "
                                 f"{', '.join(sorted(self))}") from None
        return _typed(value)

    def __dir__(self) -> List[str]:
        return sorted(set(super().__dir__()) | {k for k in self if k.isidentifier()})

    def __repr__(self) -> str:
        return f"hooke.{type(self).__name__}({dict.__repr__(self)})"


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _typed(value: Any) -> Any:
    """A JSON value as a report attribute gives it: a list of numbers, or a matrix of them,
    as a numpy array; a mapping as a :class:`Report`; anything else as it is."""
    if isinstance(value, dict):
        return Report(value)
    if isinstance(value, list) and value:
        flat = all(_number(x) for x in value)
        matrix = all(isinstance(x, list) and x and all(_number(y) for y in x) for x in value)
        if flat or (matrix and len({len(x) for x in value}) == 1):
            return np.asarray(value, dtype=float)
    return value


class Moduli(Report):
    """What :func:`moduli` measured (``hooke moduli --json``). The block test: ``E_target``,
    ``E_measured``, ``nu_target``, ``nu_measured`` and their errors, ``q``, ``size``, the
    solver's ``iterations`` and ``residual``; the bulk tests (``bulk=True``): ``C_measured``
    and ``C_target`` (6x6, Voigt order ``voigt``, Pa), ``max_relative_difference``, and on
    random lattices ``C_spread`` and ``C_affine``."""

    __slots__ = ()


class Toughness(Report):
    """What :func:`toughness` measured (``hooke toughness --json``): the fracture energy the
    strip's crack dissipated per unit area against the calibrated ``G_c`` (``ratio``), with
    the window's statistics."""

    __slots__ = ()


class Check(Report):
    """What :meth:`Simulation.check` found (``hooke check --json``): ``valid``, ``nodes``,
    ``springs``, the constants, ``dt`` and ``dt_critical``, the memory (``state_bytes``,
    ``peak_memory_bytes``), the time it would take, and ``notes`` on calibrated ranges."""

    __slots__ = ()


class Summary(Report):
    """What a finished run reports (``hooke run --json``): steps, time, broken springs,
    energy, reactions, outputs and ``output_dir``."""

    __slots__ = ()


# The columns of a run's histories (NAME_KIND.csv), typed: what ``Output.history`` returns.
_REACTION_DTYPE = np.dtype([("time", "f8"), ("force", "f8", (3,)), ("displacement", "f8", (3,))])


def _toml_value(v: Any) -> str:
    """A Python value as the TOML text of a ``--set`` override."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float, np.integer, np.floating)):
        return repr(float(v)) if isinstance(v, (float, np.floating)) else str(int(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise CaseError(f"--set value {v!r}: give a number, a bool, a string or a list of them")


class Simulation:
    """A simulation loaded from a case. It starts (opens its output folder, writes run.json and
    the first frame) on its first step; ``finish()`` writes the last frame, the checkpoint and
    the end of run.json. Arrays are read-only snapshots of the state when read."""

    def __init__(self, inner: "_hooke.Simulation"):
        self._inner = inner

    def step(self, n: int = 1) -> "Simulation":
        """Take ``n`` explicit steps (fewer if the end time comes first). Ctrl-C raises
        KeyboardInterrupt after a whole step, the simulation still usable."""
        if n < 0:
            raise CaseError(f"step(n={n}): give a number of steps, 0 or more")
        self._inner.step(int(n))
        return self

    def run(self, until: Optional[float] = None, every: Optional[float] = None,
            callback: Optional[Callable[["Simulation"], Any]] = None) -> "Simulation":
        """Step to ``until`` (s; default the case's end time), calling ``callback(sim)`` every
        ``every`` seconds of simulated time (and at ``until``)."""
        cb = None if callback is None else (lambda _inner: callback(self))
        self._inner.run(until, every, cb)
        return self

    def finish(self) -> "Summary":
        """Run to the end time and make the outputs final; returns ``hooke run --json``'s
        :class:`Summary` (steps, time, broken springs, energy, reactions, outputs,
        output_dir)."""
        return Summary(json.loads(self._inner.finish()))

    def check(self) -> "Check":
        """What the simulation would do, before its first step: ``hooke check --json``'s
        :class:`Check` from the same library call (nodes, springs, constants, dt, memory, the
        time it would take, ``notes`` on calibrated ranges). The simulation is not stepped."""
        return Check(json.loads(self._inner.check()))

    def __enter__(self) -> "Simulation":
        return self

    def __exit__(self, kind: Any, value: Any, tb: Any) -> None:
        """Leaving a ``with`` block finishes the run (runs it to its end time and makes the
        outputs final) unless the block raised."""
        if kind is None:
            self.finish()

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self._inner.time

    @property
    def steps(self) -> int:
        """Steps taken."""
        return self._inner.steps

    @property
    def end_time(self) -> float:
        return self._inner.end_time

    @property
    def dt(self) -> Optional[float]:
        """The time step (s); None before the first step."""
        return self._inner.dt

    @property
    def nodes(self) -> int:
        return self._inner.nodes

    @property
    def springs(self) -> int:
        return self._inner.springs

    @property
    def cell_weighted(self) -> bool:
        """Whether a regular lattice's springs and nodes are weighted by their cells (the
        default; ``Builder.cell_weights(False)`` turns it off)."""
        return self._inner.cell_weighted

    @property
    def out(self) -> str:
        """The output folder."""
        return self._inner.out

    @property
    def positions(self) -> np.ndarray:
        """Reference positions (m), n x 3: a read-only view of the simulation's own buffer
        (no copy; it keeps the simulation alive)."""
        return self._inner.positions

    @property
    def displacement(self) -> np.ndarray:
        """Displacements (m), n x 3: a read-only view without a copy that follows the state
        (a view taken before ``step`` or ``run`` shows the displacements after it)."""
        return self._inner.displacement

    @property
    def velocity(self) -> np.ndarray:
        """Velocities (m/s) at the current time (full step), n x 3: read-only, follows the
        state like ``displacement`` (recomputed in place when stepping returns)."""
        return self._inner.velocity

    @property
    def damage(self) -> np.ndarray:
        """Per node, the fraction of its springs that are broken (n): read-only, follows the
        state."""
        return self._inner.damage

    @property
    def spring_ends(self) -> np.ndarray:
        """Each spring's end nodes (m x 2, uint32): a read-only view without a copy."""
        return self._inner.spring_ends

    @property
    def spring_intact(self) -> np.ndarray:
        """Whether each spring is intact (m, bool): a read-only view without a copy that follows
        the state."""
        return self._inner.spring_intact

    def broken(self) -> Tuple[int, float]:
        """Springs broken so far and the energy they released (J)."""
        return self._inner.broken()

    def energy(self) -> "Report":
        """The energy ledger now (J), a :class:`Report`: kinetic, strain_direct,
        strain_dispersive, external_work, boundary_work, body_work, dissipated, released,
        balance_error (NAME_energy.csv's columns; ``sim.energy().kinetic``)."""
        return Report(json.loads(self._inner.energy_json()))

    def reactions(self) -> Dict[str, Reaction]:
        """Each boundary region's :class:`Reaction` now (force on the body in N, mean
        displacement in m, numpy arrays), by name."""
        return {r["name"]: Reaction(r["name"], r["force"], r["displacement"])
                for r in json.loads(self._inner.reactions_json())}

    def __repr__(self) -> str:
        return repr(self._inner)


def load_case(case: Union[str, os.PathLike], set: Optional[Mapping[str, Any]] = None,
              scale: float = 1.0, out: Optional[Union[str, os.PathLike]] = None,
              name: Optional[str] = None,
              overrides: Optional[Mapping[str, Any]] = None) -> Simulation:
    """Load a case from a file path or from TOML text (for text, :func:`loads` says so
    outright).

    ``overrides`` (or ``set``, its older name) changes keys as ``hooke run --set`` does
    (``{"material.poisson": 0.3}``); ``scale``
    divides the lattice spacing like ``--scale``. The output folder defaults to the command
    line's (``CASE.out`` beside the case, ``CASE.scaleS.out`` at another scale), or a new
    temporary folder for TOML text. Mistakes raise ``CaseError`` with the command line's
    ``file:line:column: key: fix`` message.
    """
    text_given = isinstance(case, str) and ("\n" in case or "=" in case) and not os.path.exists(case)
    if text_given:
        path = Path("<text>.toml")
        text = case
        stem = name or "case"
        default_out = Path(tempfile.mkdtemp(prefix="hooke-"))
    else:
        path = Path(case)
        try:
            text = path.read_text()
        except OSError as e:
            raise CaseError(f"{path}: cannot read the case file: {e.strerror}") from None
        stem = name or path.stem
        suffix = ".out" if scale == 1.0 else f".scale{scale!r}.out" if not float(scale).is_integer() else f".scale{int(scale)}.out"
        default_out = path.parent / f"{stem}{suffix}"
    if set is not None and overrides is not None:
        raise CaseError("load_case: give overrides= or set=, not both")
    given = overrides if overrides is not None else (set or {})
    pairs = [f"{k}={_toml_value(v)}" for k, v in given.items()]
    target = Path(out) if out is not None else default_out
    inner = _hooke.load_case(str(path), text, str(target), stem, pairs, float(scale),
                             ["python", "hooke.load_case", str(case) if not text_given else "<text>"])
    return Simulation(inner)


def loads(text: str, overrides: Optional[Mapping[str, Any]] = None, scale: float = 1.0,
          out: Optional[Union[str, os.PathLike]] = None, name: str = "case") -> Simulation:
    """Load a case from TOML text (as :func:`load_case` does with a path): the output folder
    defaults to a new temporary one."""
    stem = name
    target = Path(out) if out is not None else Path(tempfile.mkdtemp(prefix="hooke-"))
    pairs = [f"{k}={_toml_value(v)}" for k, v in (overrides or {}).items()]
    inner = _hooke.load_case("<text>.toml", text, str(target), stem, pairs, float(scale),
                             ["python", "hooke.loads", "<text>"])
    return Simulation(inner)


# Options that take a list; a single number is a list of one (as ``--size 33`` on the command line).
_LIST_OPTIONS = ("size", "transverse", "orthotropic", "axes")


def _options(lattice: str, nu: Optional[float], flags: Mapping[str, Any]) -> str:
    """Keyword arguments as the experiment's options (JSON): the command's flags by name
    (``sweep_nu`` for ``--sweep-nu``), None left out (``nu`` too); ``fibre=[1, 1, 0]`` as
    ``"1,1,0"``."""
    opts: Dict[str, Any] = {"lattice": str(lattice)}
    if nu is not None:
        opts["nu"] = float(nu)
    for k, v in flags.items():
        if v is None:
            continue
        if k in _LIST_OPTIONS and not isinstance(v, (list, tuple)):
            v = [v]
        elif k == "fibre" and isinstance(v, (list, tuple)):
            v = ",".join(repr(float(x)) for x in v)
        elif isinstance(v, tuple):
            v = list(v)
        opts[k] = v
    return json.dumps(opts)


def ramp(to: float, t1: float, t0: float = 0.0, start: float = 0.0) -> Dict[str, List[float]]:
    """A time function: ``start`` until ``t0``, linear to ``to`` at ``t1``, then ``to``."""
    return {"ramp": [t0, t1, start, to]}


def smooth_ramp(to: float, t1: float, t0: float = 0.0, start: float = 0.0) -> Dict[str, List[float]]:
    """A half-cosine ramp from ``start`` to ``to`` between ``t0`` and ``t1`` (no shock)."""
    return {"smooth": [t0, t1, start, to]}


def table(points: Any) -> Dict[str, List[List[float]]]:
    """A piecewise-linear time function through ``[(t, value), ...]``."""
    return {"table": [[float(t), float(v)] for t, v in points]}


class Builder:
    """A simulation built in code, for cases easier as code than as a file: the library's
    builder (``hooke_sim::Builder``) with the same checks and messages: each call is applied
    as it is made, and a mistake raises ``CaseError`` there, naming the call. Regions: ``hooke.All()``, ``hooke.Face("y+")``,
    ``hooke.Plane("x", 0.0)``, ``hooke.Nodes([...])`` or a shape (the nodes inside it); shapes:
    ``hooke.Box(min, max)``, ``hooke.Sphere(center, radius)``, ``hooke.Cylinder(center, axis,
    radius, length)``. The older forms still work: ``"all"``, ``{"face": "y+"}``,
    ``{"box": {"min": [...], "max": [...]}}``, ``{"plane": {"axis": "x", "at": 0.0}}``,
    ``{"inside": SHAPE}``, ``{"nodes": [...]}``; shapes: ``{"box": {min, max}}``,
    ``{"sphere": {"center", "radius"}}``, ``{"cylinder": {"center", "axis", "radius",
    "length"}}``; time functions: a number, ``ramp(...)``, ``smooth_ramp(...)``, ``table(...)``.

        sim = (hooke.Builder("random2d", spacing=0.5e-3).thickness(1e-3)
               .box([0, 0], [60e-3, 30e-3]).material(72e9, 0.22, 2440).fracture_energy(3.8)
               .boundary(hooke.Face("y+"), velocity={"y": hooke.smooth_ramp(0.02, 5e-6)})
               .end_time(60e-6).output_every(1e-6).build("out", "plate"))
    """

    def __init__(self, lattice: str, spacing: float):
        self._inner = _hooke.Builder(str(lattice), float(spacing))

    def _call(self, name: str, arg: Any = None) -> "Builder":
        # Applied to the library's builder now: a mistake raises here, at its call.
        self._inner.call(name, arg)
        return self

    def thickness(self, h: float) -> "Builder":
        """Plate thickness (m), 2D lattices."""
        return self._call("thickness", float(h))

    def plane(self, model: str) -> "Builder":
        """2D: ``"stress"`` (thin plate) or ``"strain"``."""
        return self._call("plane", model)

    def box(self, lo: Any, hi: Any) -> "Builder":
        """The body is this box (m)."""
        return self._call("box", {"min": list(lo), "max": list(hi)})

    def add(self, shape: Any) -> "Builder":
        """The body is the union of the added shapes (instead of a box)."""
        return self._call("add", _shape(shape))

    def subtract(self, shape: Any) -> "Builder":
        return self._call("subtract", _shape(shape))

    def material(self, youngs: float, poisson: float, density: float) -> "Builder":
        """E (Pa), nu (any value in (-1, 1/2)), rho (kg/m^3)."""
        return self._call("material", {"youngs": youngs, "poisson": poisson, "density": density})

    def material_name(self, name: str) -> "Builder":
        """The body's material's name (default ``"material"``): phase 0 of a body of several
        materials, and what an ``interface`` calls it (``material.name`` in a case file)."""
        return self._call("material_name", str(name))

    def weibull(self, modulus: float, seed: int = 0) -> "Builder":
        """Scatter the body's material's critical stretches: each spring's is the criterion's
        times a Weibull draw of ``modulus`` (1 to 100) that follows the seed and the nodes the
        spring joins (``material.weibull`` in a case file)."""
        return self._call("weibull", {"modulus": float(modulus), "seed": int(seed)})

    @staticmethod
    def _phase_material(name: str, youngs: float, poisson: float, density: float,
                        critical_stretch: Optional[float], fracture_energy: Optional[float],
                        weibull: Optional[Tuple[float, int]]) -> Dict[str, Any]:
        arg: Dict[str, Any] = {"name": str(name), "youngs": float(youngs),
                               "poisson": float(poisson), "density": float(density)}
        if critical_stretch is not None:
            arg["critical_stretch"] = float(critical_stretch)
        if fracture_energy is not None:
            arg["fracture_energy"] = float(fracture_energy)
        if weibull is not None:
            arg["weibull"] = {"modulus": float(weibull[0]), "seed": int(weibull[1])}
        return arg

    def phase(self, shape: Any, name: str, youngs: float, poisson: float, density: float,
              critical_stretch: Optional[float] = None, fracture_energy: Optional[float] = None,
              weibull: Optional[Tuple[float, int]] = None) -> "Builder":
        """The nodes inside ``shape`` are of the material ``name`` (a later phase overrides an
        earlier one; the body's ``material`` fills the rest), as ``[[phases]]`` and
        ``[materials.NAME]`` in a case file. Its springs may break at their own
        ``critical_stretch`` or ``fracture_energy``, and scatter by ``weibull=(modulus, seed)``."""
        arg = self._phase_material(name, youngs, poisson, density, critical_stretch,
                                   fracture_energy, weibull)
        arg["shape"] = _shape(shape)
        return self._call("phase", arg)

    def inclusions(self, name: str, youngs: float, poisson: float, density: float,
                   d_min: float, d_max: float, fraction: float, grading: str = "fuller",
                   gap: float = 0.0, seed: int = 0, fuller_exponent: float = 0.5,
                   critical_stretch: Optional[float] = None,
                   fracture_energy: Optional[float] = None,
                   weibull: Optional[Tuple[float, int]] = None) -> "Builder":
        """Random non-overlapping spheres (disks in 2D) of the material ``name``: diameters
        from ``d_min`` to ``d_max`` (m) by ``grading`` (``"fuller"`` or ``"uniform"``), a volume
        ``fraction`` of the body, at least ``gap`` (m) apart, from ``seed``; as
        ``[[inclusions]]`` in a case file. A fraction beyond reach is refused at ``build`` with
        the fraction reached."""
        arg = self._phase_material(name, youngs, poisson, density, critical_stretch,
                                   fracture_energy, weibull)
        arg.update({"d_min": float(d_min), "d_max": float(d_max), "fraction": float(fraction),
                    "grading": str(grading), "gap": float(gap), "seed": int(seed),
                    "fuller_exponent": float(fuller_exponent)})
        return self._call("inclusions", arg)

    def interface(self, between: Any, critical_stretch: Optional[float] = None,
                  fracture_energy: Optional[float] = None,
                  stiffness_factor: float = 1.0) -> "Builder":
        """The springs between two named materials take their own ``critical_stretch`` or
        ``fracture_energy`` and a ``stiffness_factor``, as ``[[interfaces]]`` in a case file."""
        arg: Dict[str, Any] = {"between": [str(m) for m in between],
                               "stiffness_factor": float(stiffness_factor)}
        if critical_stretch is not None:
            arg["critical_stretch"] = float(critical_stretch)
        if fracture_energy is not None:
            arg["fracture_energy"] = float(fracture_energy)
        return self._call("interface", arg)

    def transverse(self, youngs_plane: float, youngs_fibre: float, poisson_plane: float,
                   poisson_fibre: float, shear_fibre: float, fibre: Any,
                   density: float) -> "Builder":
        """A transversely isotropic material, as ``kind = "transverse"`` in a case file (the
        cubic lattice, ``fibre`` along a lattice axis): E_p, E_t (Pa), nu_p, nu_tp, G_t (Pa),
        the fibre direction [x, y, z] and rho (``docs/anisotropy.md``). Instead of
        ``material``."""
        return self._call("transverse", {
            "youngs_plane": youngs_plane, "youngs_fibre": youngs_fibre,
            "poisson_plane": poisson_plane, "poisson_fibre": poisson_fibre,
            "shear_fibre": shear_fibre, "fibre": [float(v) for v in fibre], "density": density})

    def rotate_lattice(self, direction: Any) -> "Builder":
        """Lay the cubic lattice along ``direction`` (a fibre's), as ``lattice.rotate_to``."""
        return self._call("rotate_lattice", [float(v) for v in direction])

    def cell_weights(self, on: bool) -> "Builder":
        """Weight a regular lattice's springs and nodes by the share of the bulk's cells each
        stands for, as ``lattice.cell_weights`` (on by default where the lattice allows it: no
        free-surface bias in the moduli); ``False`` gives every spring the bulk stiffness."""
        return self._call("cell_weights", bool(on))

    def orthotropic(self, youngs: Any, poisson: Any, shear: Any, density: float,
                    axes: Any = None) -> "Builder":
        """An orthotropic material, as ``kind = "orthotropic"``: ``youngs`` [E_x, E_y, E_z],
        ``poisson`` [nu_xy, nu_xz, nu_yz], ``shear`` [G_yz, G_xz, G_xy] (Pa), rho, in its
        material axes: the body's, or ``axes`` [[x], [y]] (the material x and y directions,
        as ``material.axes``), along which the cubic lattice is then laid. Instead of
        ``material``."""
        arg: Dict[str, Any] = {
            "youngs": [float(v) for v in youngs], "poisson": [float(v) for v in poisson],
            "shear": [float(v) for v in shear], "density": density}
        if axes is not None:
            arg["axes"] = [[float(c) for c in v] for v in axes]
        return self._call("orthotropic", arg)

    def fracture_energy(self, g_c: float) -> "Builder":
        """G_c (J/m^2): springs break, calibrated so that cracks dissipate G_c."""
        return self._call("fracture_energy", float(g_c))

    def precrack(self, a: Any, b: Any = None) -> "Builder":
        """2D: the springs crossing the segment a-b are removed; 3D: pass the polygon's
        vertices as ``a`` (a list of [x, y, z])."""
        if b is None:
            return self._call("precrack_polygon", [list(v) for v in a])
        return self._call("precrack_segment", {"a": list(a), "b": list(b)})

    def boundary(self, region: Any, fixed: Any = (), velocity: Optional[Mapping[str, Any]] = None,
                 displacement: Optional[Mapping[str, Any]] = None, no_fail: bool = False,
                 name: Optional[str] = None, traction: Any = None, normal: str = "y",
                 scale: Any = 1.0) -> "Builder":
        """Conditions on a region: ``fixed`` axes, prescribed ``velocity`` or ``displacement``
        per axis (``{"y": 0.02}`` or a time function), a ``traction`` (Pa, a vector, spread
        over the region's area normal to the axis ``normal``, times the time function
        ``scale``), ``no_fail`` springs, a ``name`` for the reactions."""
        arg: Dict[str, Any] = {"region": _region(region), "fixed": list(fixed), "no_fail": no_fail}
        if velocity:
            arg["velocity"] = dict(velocity)
        if displacement:
            arg["displacement"] = dict(displacement)
        if traction is not None:
            arg["traction"] = {"value": list(traction), "normal": normal, "scale": scale}
        if name:
            arg["name"] = name
        return self._call("boundary", arg)

    def initial_velocity(self, region: Any, v: Any) -> "Builder":
        return self._call("initial_velocity", {"region": _region(region), "velocity": list(v)})

    def gravity(self, g: Any) -> "Builder":
        """Body acceleration (m/s^2)."""
        return self._call("gravity", list(g))

    def end_time(self, t: float) -> "Builder":
        return self._call("end_time", float(t))

    def output_every(self, t: float) -> "Builder":
        return self._call("output_every", float(t))

    def checkpoint_every(self, t: float) -> "Builder":
        return self._call("checkpoint_every", float(t))

    def damping(self, c: float) -> "Builder":
        """Mass-proportional damping c (1/s)."""
        return self._call("damping", float(c))

    def random(self, seed: int = 1, sampler: str = "poisson", jitter: float = 0.6) -> "Builder":
        """Node set of a random lattice: the sampler (``"poisson"``: blue noise, or
        ``"jitter"``: a grid whose nodes move by up to ``jitter`` spacings) and its seed."""
        return self._call("random", {"seed": int(seed), "sampler": sampler,
                                     "jitter": float(jitter)})

    def breaking(self, stretch: Optional[float] = None, fracture_energy: Optional[float] = None,
                 criterion: str = "stretch",
                 stretch_fibre: Optional[float] = None) -> "Builder":
        """The breaking rule: a critical ``stretch``, or a ``fracture_energy`` G_c (J/m^2)
        through the measured lattice toughness; ``criterion="energy"`` takes the spring-energy
        criterion matched to either (regular lattices). A transverse material may add
        ``stretch_fibre``, the critical stretch along its fibre (``stretch`` is then the one
        across it), as ``critical_stretch_fibre`` in a case file."""
        if (stretch is None) == (fracture_energy is None):
            raise CaseError("breaking: give stretch or fracture_energy, one of them")
        arg: Dict[str, Any] = {"criterion": criterion}
        if stretch_fibre is not None:
            arg["stretch_fibre"] = float(stretch_fibre)
        if stretch is not None:
            arg["stretch"] = float(stretch)
        else:
            arg["fracture_energy"] = float(fracture_energy)  # type: ignore[arg-type]
        return self._call("breaking", arg)

    def softening(self, fracture_energy: Optional[float] = None,
                  tensile_strength: Optional[float] = None,
                  characteristic_length: Optional[float] = None,
                  peak_stretch: Optional[float] = None, final_stretch: Optional[float] = None,
                  shape: str = "linear") -> "Builder":
        """Softening (cohesive) springs, as ``criterion = "softening"`` in a case file: a
        ``fracture_energy`` G_f (J/m^2) with a ``tensile_strength`` f_t (Pa) or a
        ``characteristic_length`` E G_f / f_t^2 (m), or the curve's ``peak_stretch`` and
        ``final_stretch``; ``shape`` is ``"linear"`` or ``"bilinear"``."""
        arg: Dict[str, Any] = {"shape": shape}
        for k, v in (("fracture_energy", fracture_energy), ("tensile_strength", tensile_strength),
                     ("characteristic_length", characteristic_length),
                     ("peak_stretch", peak_stretch), ("final_stretch", final_stretch)):
            if v is not None:
                arg[k] = float(v)
        return self._call("softening", arg)

    def time_step(self, safety: Optional[float] = None, dt: Optional[float] = None,
                  force: bool = False) -> "Builder":
        """The explicit step: a ``safety`` factor on the stable step (default 0.8), or a fixed
        ``dt`` (s), refused above the stable step unless ``force``."""
        if (safety is None) == (dt is None):
            raise CaseError("time_step: give safety or dt, one of them")
        if dt is not None:
            return self._call("time_step", {"dt": float(dt), "force": bool(force)})
        return self._call("time_step", {"safety": float(safety)})  # type: ignore[arg-type]

    def quasi_static(self, steps: int) -> "Builder":
        """Solve ``steps`` equilibrium load steps to the end time instead of dynamics (the
        simulation then runs with ``finish()``)."""
        return self._call("quasi_static", int(steps))

    def reactions_every(self, t: float) -> "Builder":
        """Write the regions' reactions every ``t`` seconds besides the frames."""
        return self._call("reactions_every", float(t))

    def formats(self, vtk: bool = True, hdf5: bool = False) -> "Builder":
        """Output formats (HDF5 needs the package built with the ``hdf5`` feature)."""
        return self._call("formats", {"vtk": bool(vtk), "hdf5": bool(hdf5)})

    def springs(self, on: bool = True) -> "Builder":
        """Write the intact springs as lines in the VTK frames."""
        return self._call("springs", bool(on))

    def rigid(self, shape: Any, position: Any = None, velocity: Any = (0.0, 0.0, 0.0),
              motion: str = "dynamic", mass: Optional[float] = None,
              density: Optional[float] = None, friction: float = 0.0,
              name: Optional[str] = None, angular_velocity: Optional[Any] = None,
              rotates: Optional[bool] = None, start_gap: Optional[float] = None) -> "Builder":
        """A rigid body in contact with the lattice, as the case file's ``[[rigid]]``:
        ``shape`` a :class:`Shape` (``hooke.Sphere(center, radius)``, ``Box``, ``Cylinder``,
        ``Capsule``, ``HalfSpace``; the body starts at its centre unless ``position`` is given)
        or one of ``{"sphere": {"radius"}}``, ``{"box": {"size": [...]}}``,
        ``{"cylinder": {"radius", "length", "axis"}}``, ``{"capsule": {...}}``,
        ``{"halfspace": {"normal": [...]}}``; ``motion`` ``"dynamic"`` (with ``mass`` or
        ``density``) or ``"kinematic"`` (moves at ``velocity``). ``angular_velocity`` (rad/s;
        ``[wx, wy, wz]`` in 3D, ``[wz]`` in 2D) is a kinematic body's constant spin or a dynamic
        body's initial one; a dynamic body turns under the contact torques unless
        ``rotates=False``. ``start_gap`` (m) moves the body along its velocity until the nearest
        node is that far outside its contact range, as in a case file."""
        if isinstance(shape, Shape):
            shape, centre = shape._rigid()
            position = centre if position is None else position
        if position is None:
            raise CaseError("rigid: give the body's position (or a shape with a centre)")
        arg: Dict[str, Any] = {"shape": dict(shape), "position": list(position),
                               "velocity": list(velocity), "motion": motion,
                               "friction": float(friction)}
        if mass is not None:
            arg["mass"] = float(mass)
        if density is not None:
            arg["density"] = float(density)
        if name:
            arg["name"] = name
        if angular_velocity is not None:
            arg["angular_velocity"] = [float(w) for w in angular_velocity]
        if rotates is not None:
            arg["rotates"] = bool(rotates)
        if start_gap is not None:
            arg["start_gap"] = float(start_gap)
        return self._call("rigid", arg)

    def contact(self, stiffness_factor: float = 0.1, radius: Optional[float] = None,
                fragments: bool = True, fragment_distance: Optional[float] = None) -> "Builder":
        """Contact options (as ``[contact]``): on with these; the defaults are the lattice's."""
        arg: Dict[str, Any] = {"stiffness_factor": float(stiffness_factor),
                               "fragments": bool(fragments)}
        if radius is not None:
            arg["radius"] = float(radius)
        if fragment_distance is not None:
            arg["fragment_distance"] = float(fragment_distance)
        return self._call("contact", arg)

    def build(self, out: Union[str, os.PathLike], name: str = "run") -> Simulation:
        """The simulation; it writes to ``out`` (files named ``name``) once it steps."""
        return Simulation(self._inner.build(str(out), name))


def moduli(lattice: str = "cubic", nu: Optional[float] = 0.3, **flags: Any) -> "Moduli":
    """The paper's block test, as ``hooke moduli --lattice LATTICE --nu NU ... --json``: the
    same keys and numbers. Other flags by name (``size=[21, 6, 6]``, ``samples=4``,
    ``sampler="jitter"``; ``bulk=True``: the exact bulk test's 6x6 ``C_measured`` and
    ``C_target``, on random lattices the relaxed one's with ``C_spread`` and ``C_affine``;
    regular lattices' springs and nodes are weighted by their cells (no surface bias) unless
    ``cell_weights=False`` (``--equal-weights``, the paper's plain block);
    ``transverse=[E_p, E_t, nu_p, nu_tp, G_t]`` with ``fibre="z"``, or
    ``orthotropic=[E_x, E_y, E_z, nu_xy, nu_xz, nu_yz, G_yz, G_xz, G_xy]``, with
    ``axes=[X1, Y1, Z1, X2, Y2, Z2]`` turned against the body: an anisotropic material instead
    of ``nu``)."""
    if flags.get("transverse") is not None or flags.get("orthotropic") is not None:
        nu = None
    if flags.get("cell_weights") is False:
        # Weighted is the default: False asks for the old equal weights, not for nothing.
        flags = {k: v for k, v in flags.items() if k != "cell_weights"}
        flags["equal_weights"] = True
    return Moduli(json.loads(_hooke.moduli_json(_options(lattice, nu, flags))))


def toughness(lattice: str = "hex", nu: float = 0.25, **flags: Any) -> "Toughness":
    """The fracture energy a lattice crack dissipates in a strip under fixed grips, against
    the G_c calibration, as ``hooke toughness --lattice LATTICE --nu NU ... --json`` (same keys
    and numbers). Other flags by name (``height=20``, ``window=4``, ``criterion="energy"``)."""
    return Toughness(json.loads(_hooke.toughness_json(_options(lattice, nu, flags))))


class Output:
    """A run's output folder as written by ``hooke run`` or by ``Simulation``: the frames of
    its ``.pvd`` series, the energy history and run.json."""

    def __init__(self, folder: Union[str, os.PathLike]):
        self.folder = Path(folder)
        pvds = sorted(self.folder.glob("*.pvd"))
        pvds = [p for p in pvds if not p.stem.endswith("_rigid")]
        if not pvds:
            raise CaseError(f"{self.folder}: no .pvd series here (is it a hooke output folder?)")
        self.name = pvds[0].stem
        root = ET.parse(pvds[0]).getroot()
        sets = root.iter("DataSet")
        pairs = sorted((float(d.get("timestep")), self.folder / d.get("file")) for d in sets)
        self.times = np.array([t for t, _ in pairs])
        self.files = [f for _, f in pairs]
        info = self.folder / "run.json"
        self.info: Dict[str, Any] = json.loads(info.read_text()) if info.exists() else {}

    def __len__(self) -> int:
        return len(self.files)

    def fields(self, i: int = -1) -> Dict[str, np.ndarray]:
        """Frame ``i``'s point fields as numpy arrays (meshio), plus ``points``."""
        import meshio

        m = meshio.read(self.files[i])
        out = {k: np.asarray(v) for k, v in m.point_data.items()}
        out["points"] = np.asarray(m.points)
        return out

    def mesh(self, i: int = -1):
        """Frame ``i`` as a pyvista mesh."""
        import pyvista

        return pyvista.read(self.files[i])

    def energy(self) -> Dict[str, np.ndarray]:
        """The energy history (NAME_energy.csv) by column."""
        data = self.history("energy")
        return {k: np.asarray(data[k]) for k in data.dtype.names}

    def history(self, kind: str = "energy") -> np.ndarray:
        """A history (NAME_KIND.csv: ``"energy"``, ``"reactions"`` or ``"contact"``) as a
        structured numpy array, one record per line, a field per column (``h["time"]``,
        ``h["kinetic"]``; ``pandas.DataFrame(h)`` makes a frame of it)."""
        path = self.folder / f"{self.name}_{kind}.csv"
        if not path.exists():
            have = sorted(p.name for p in self.folder.glob(f"{self.name}_*.csv"))
            raise CaseError(f"{path}: no such history here (this run wrote {', '.join(have) or 'none'})")
        # The header comment (a history may open with "# hooke ...") is not the column names.
        lines = [l for l in path.read_text().splitlines() if l and not l.startswith("#")]
        data = np.genfromtxt(lines, delimiter=",", names=True, dtype=None, encoding="utf-8")
        return np.atleast_1d(data)

    def reactions(self) -> Dict[str, np.ndarray]:
        """The reactions history by region name: a structured array per region with fields
        ``time`` (s), ``force`` (N, 3 per record) and ``displacement`` (m, 3 per record)."""
        h = self.history("reactions")
        out: Dict[str, np.ndarray] = {}
        for name in dict.fromkeys(h["name"].tolist()):
            rows = h[h["name"] == name]
            a = np.empty(len(rows), dtype=_REACTION_DTYPE)
            a["time"] = rows["time"]
            a["force"] = np.stack([rows[f"force_{c}"] for c in "xyz"], axis=1)
            a["displacement"] = np.stack([rows[f"displacement_{c}"] for c in "xyz"], axis=1)
            out[str(name)] = a
        return out


def read(folder: Union[str, os.PathLike]) -> Output:
    """Open a run's output folder: ``out.times``, ``out.fields(i)``, ``out.mesh(i)``,
    ``out.energy()``, ``out.history(kind)`` and ``out.reactions()`` (structured numpy arrays),
    ``out.info`` (run.json)."""
    return Output(folder)
