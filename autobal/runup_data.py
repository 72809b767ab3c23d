"""A measured run-up or coast-down read into 1x vectors (:class:`OneX`), in SI and the toolkit's conventions.

Two kinds of file are read, both CSV texts whose header cells read ``quantity [unit]`` (as the rig files of
:mod:`autobal.measurements`: ``#`` comment lines, UTF-8 with or without a byte-order mark, ',' or, in a
spreadsheet export, ';' with decimal commas; ``columns`` names the columns to take by their headers, others
skipped, e.g. ``{"speed": "Drehzahl (rpm)", "amplitude": "Amplitude (µm)", "phase": "Phase (°)"}``).

**1x vectors** (:func:`read_vectors`), one row per vector as a vibration analyser exports them, in time order:

==========================  ===========================  ====================================================
header                      unit                         meaning
==========================  ===========================  ====================================================
``speed``                   rpm, r/min, Hz, rad/s        shaft speed (required)
``time``                    s, ms, min                   time stamp (optional; then it must rise)
``amplitude``               µm (um), mm, m               1x amplitude of probe x (required; also ``amplitude_x``)
``phase``                   deg (°), rad                 1x phase of probe x from the key-phasor (required;
                                                         also ``phase_x``)
``amplitude_y``, ``phase_y``  as above                   probe y, 90° from x in the direction of rotation
                                                         (optional, both or neither)
==========================  ===========================  ====================================================

The conventions are the caller's (the scene's): ``amplitude`` "0-peak" or "peak-to-peak", ``phase`` "lag" or
"lead".  A header may state its own with a suffix: ``amplitude_pp`` / ``amplitude_0p`` (``amplitude_x_pp``,
``amplitude_y_0p``, ...) and ``phase_lag`` / ``phase_lead`` (``phase_y_lag``, ...); a suffix that contradicts
the caller's convention is refused, never silently converted twice.

**Raw signals** (:func:`read_signals`), one row per sample:

==================  ================  ====================================================================
header              unit              meaning
==================  ================  ====================================================================
``time``            s, ms             sample time (required, rising)
``probe_x``         µm (um), mm, m    displacement of probe x (required)
``probe_y``         µm (um), mm, m    displacement of probe y, 90° from x in the direction of rotation
``keyphasor``       V, mV or 1        once-per-turn pulse (a voltage or a 0/1 channel)
``speed``           rpm, Hz, rad/s    shaft speed (a tachometer), used when there is no ``keyphasor``
==================  ================  ====================================================================

Conventions of the result: ``x(t) = Re(X exp(i phi(t)))`` with ``X`` the complex 0-peak 1x amplitude in m and
``phi`` the shaft angle since the key-phasor pulse (0 at the pulse), positive in the direction of rotation.
An analyser's phase lag ``theta`` (the probe's peak comes ``theta`` degrees of rotation after the pulse) is
``X = A exp(-i theta)``; a phase lead is ``X = A exp(+i theta)``.

What the reading does, each step stated in :attr:`OneX.notes`:

- units from the headers to SI; a peak-to-peak amplitude halved; the phase turned into the convention above;
- a phase wrapped by the analyser at ±180° or 0-360° is unwrapped (a step of 360° is a wrap; the vector
  itself does not change); a step that no multiple of 360° explains, of more than :data:`MAX_PHASE_STEP`
  between neighbouring vectors that stand above the noise, is refused (a key-phasor slip, a sign change, or
  a phase turn the speed steps do not resolve);
- ``slow_roll=(low, high)`` in rad/s: the mean 1x vector of the vectors in that speed range (the run-out and
  electrical run-out of the probe track) is subtracted from every vector of its probe;
- raw signals: order tracking per revolution.  The key-phasor's two levels are found from the channel
  (the medians either side of its mid-range), the pulses are the edges through the level halfway between them
  (with hysteresis, a quarter of the step), interpolated between samples; the pulse is the rarer state (a
  projection gives a rising edge, a notch a falling one).  Between two pulses the shaft angle is interpolated
  linearly in time, and the revolution's 1x vector is ``X = (1/pi) int_0^2pi x(phi) exp(-i phi) dphi``
  (trapezoids on the samples, ``x`` interpolated at the pulses), at the speed ``2 pi / T`` of the revolution
  and the time of its middle.  A revolution more than :data:`LONG_REVOLUTION` times its shorter neighbour is a
  missed pulse: dropped and noted (more than :data:`MAX_MISSED` of them: refused); one shorter than its
  neighbours by that factor is a spurious pulse: refused.  Without a key-phasor the speed channel is
  integrated to the angle, whose zero (the first sample) is arbitrary: the phase is then relative, and an error
  of the speed channel drifts it.  Revolutions whose speed dithers on a plateau (within
  :data:`DITHER` of the run's extreme so far) are dropped so that the speed is strictly monotonic.

Refused, each with one line naming the file, the line or column and the unit (:class:`ScenarioError`): an
empty cell or a NaN, a negative amplitude, a speed that is not positive, a repeated speed, speeds out of order
or a run-up and a coast-down in one file (one file, one direction), time stamps that do not rise, a
contradictory header, fewer than :data:`MIN_VECTORS` vectors, no key-phasor and no speed channel, a slow-roll
range that holds no vector.

Not detectable, so not checked: a phase column written in radians but headed ``[deg]`` (values within ±6.3
are possible phases in degrees; a note says so when every phase lies in that band), a probe y mounted against
the direction of rotation (its vectors come out mirrored), and an amplitude convention mislabelled by the
analyser itself.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from autobal.errors import ScenarioError
from autobal.measurements import MAX_POINTS, _cells, _numbers, _rows, _select, resolve
from autobal.units import unit_factor

MIN_VECTORS = 5  # 10 real values for the at most 5 parameters of a run-up fit (critical, damping, unbalance x, y,
# modal mass), with degrees of freedom left for the residual variance
MAX_PHASE_STEP = 90.0  # deg between neighbouring vectors: a Jeffcott rotor turns its phase by about
# (step / omega_n) / zeta rad per speed step at the critical (38° at zeta = 0.005 and 10 rpm steps at 3000 rpm);
# beyond 90° the speed steps do not resolve the turn, and near 180° its sense is ambiguous
PHASE_FLOOR = 0.25  # the phase steps are checked between vectors of at least this fraction of the largest
# amplitude: the phase of a vector in the noise (slow roll) is random
LONG_REVOLUTION = 1.5  # a revolution this many times its neighbour missed a pulse (the period of a run-up
# changes by 2 pi alpha / omega^2 per revolution: 25 % at 50 rad/s and 100 rad/s^2)
MAX_MISSED = 0.1  # fraction of revolutions with a missed pulse beyond which the key-phasor is refused
DITHER = 0.01  # relative speed dither on a plateau dropped from tracked revolutions; a larger fall is a reversal
MAX_SAMPLES = 2_000_000  # rows of a raw-signal file (within autobal.measurements.MAX_DATA_BYTES)
_ANGLE = {"deg": math.pi / 180, "°": math.pi / 180, "degree": math.pi / 180, "rad": 1.0}
_VECTOR = re.compile(r"^(amplitude|phase)(?:_(x|y))?(?:_(pp|0p|lag|lead))?$")
_CONVENTION = {"pp": "peak-to-peak", "0p": "0-peak", "lag": "lag", "lead": "lead"}
_EXAMPLE = "speed [rpm],amplitude [um],phase [deg]"
_SIGNAL_EXAMPLE = "time [s],probe_x [um],keyphasor [V]"


@dataclass(frozen=True)
class OneX:
    """1x vectors of a run-up or coast-down, in SI, in the toolkit's conventions."""

    speed: np.ndarray  # shaft speed, rad/s, at each vector (strictly monotonic after reading)
    x: np.ndarray  # complex 0-peak 1x amplitude of probe x, m: x(t) = Re(X * exp(1j*phi(t))),
    # phi = shaft angle since the key-phasor pulse (0 at the pulse), positive in the
    # direction of rotation; so the analyser's phase LAG in degrees is -angle(X)
    y: np.ndarray | None  # the same for probe y (90° from x in the direction of rotation), or None
    time: np.ndarray | None  # s, at each vector (None: the file has no time stamps)
    path: str  # file it came from ('' if made in code)
    notes: tuple[str, ...]  # what the reading did (slow-roll subtracted, conventions converted, ...)


def _um(v: complex) -> str:
    return f"{abs(v) * 1e6:.3g} µm at {np.degrees(-np.angle(v)):.0f}° lag"


def _rpm(w: float) -> str:
    return f"{w * 30 / math.pi:.0f} rpm"


class _Table:
    """The columns of a measured CSV read to SI by quantity name; ``lines`` the file's line of each row."""

    def __init__(self, path, columns, folder, kinds, example, max_rows):
        self.path = resolve(path, folder)
        _, rows, sep = _rows(self.path)
        if not rows:
            raise ScenarioError(f"{self.path}: no header row (expected e.g. '{example}')")
        (head_line, header), body = rows[0], rows[1:]
        selected = _select(self.path, head_line, header, columns, where="columns", example=example)
        if not body:
            raise ScenarioError(f"{self.path}: no data rows")
        if len(body) > max_rows:
            raise ScenarioError(f"{self.path}: {len(body)} data rows; a file of this kind holds at most {max_rows}")
        for lineno, row in body:
            if len(row) != len(header):
                raise ScenarioError(f"{self.path}: line {lineno}: {len(row)} values, the header has {len(header)}")
        self.lines = np.array([lineno for lineno, _ in body])
        self.values, self.units = {}, {}
        for j, name, unit in selected:
            kind = kinds(name)
            if kind is None:
                raise ScenarioError(f"{self.path}: column {j + 1}: unknown quantity {name!r}; expected e.g. "
                                    f"'{example}' (the formats: autobal.runup_data)")
            if name in self.values:
                raise ScenarioError(f"{self.path}: column {name!r} appears twice")
            factor = self._factor(name, unit, kind)
            label = f"{name} [{unit}]"
            v = _numbers(self.path, _cells(body, j, sep), list(self.lines), label, "label")
            self.values[name], self.units[name] = v * factor, unit

    def _factor(self, name: str, unit: str, kind: str) -> float:
        cell = f"'{name} [{unit}]'"
        if kind == "angle":
            if unit.strip() not in _ANGLE:
                raise ScenarioError(f"{self.path}: column {cell}: {unit!r} is not a unit of a phase: write deg or rad")
            return _ANGLE[unit.strip()]
        if kind == "pulse":
            if unit.strip() in ("1", "-", "", "V"):
                return 1.0
            if unit.strip() == "mV":
                return 1e-3
            raise ScenarioError(f"{self.path}: column {cell}: {unit!r} is not a unit of a key-phasor: write V, mV "
                                f"or 1 (a 0/1 channel)")
        try:
            return unit_factor(unit, kind)
        except ValueError as exc:
            raise ScenarioError(f"{self.path}: column {cell}: {exc} (a {kind})") from None

    def line(self, i: int) -> int:
        return int(self.lines[i])



def _vector_kind(name: str) -> str | None:
    """The unit kind of a column of a 1x-vector file, or None for a name outside its vocabulary."""
    if name in ("speed", "time"):
        return {"speed": "angular speed", "time": "time"}[name]
    m = _VECTOR.match(name)
    if m is None or (m.group(3) is not None and (m.group(3) in ("pp", "0p")) != (m.group(1) == "amplitude")):
        return None
    return "length" if m.group(1) == "amplitude" else "angle"


def _signal_kind(name: str) -> str | None:
    """The unit kind of a column of a raw-signal file, or None."""
    return {"time": "time", "probe_x": "length", "probe_y": "length", "keyphasor": "pulse",
            "speed": "angular speed"}.get(name)


def _conventions(amplitude: str, phase: str) -> None:
    if amplitude not in ("0-peak", "peak-to-peak"):
        raise ScenarioError(f"amplitude: {amplitude!r} is no amplitude convention: write '0-peak' or 'peak-to-peak'")
    if phase not in ("lag", "lead"):
        raise ScenarioError(f"phase: {phase!r} is no phase convention: write 'lag' or 'lead' (from the key-phasor)")


def _probe_column(table: _Table, what: str, probe: str) -> tuple[str, str | None] | None:
    """(column name, the convention its suffix states) of ``what`` (amplitude, phase) of ``probe``, or None."""
    found = [(n, m.group(3)) for n in table.values if (m := _VECTOR.match(n)) and m.group(1) == what
             and (m.group(2) or "x") == probe]
    if len(found) > 1:
        raise ScenarioError(f"{table.path}: columns {' and '.join(repr(n) for n, _ in found)} both give the {what} "
                            f"of probe {probe}; keep one")
    return found[0] if found else None


def read_vectors(path, *, amplitude: str, phase: str, speed_unit: str | None = None, slow_roll=None,
                 columns: dict | None = None, folder=None) -> OneX:
    """Read a CSV of 1x vectors (speed, amplitude, phase per row; the formats in the module docstring).

    Parameters
    ----------
    path : str or Path
        The file: absolute, or relative to ``folder`` (the scene file's folder; default the working folder).
    amplitude : {"0-peak", "peak-to-peak"}
        The amplitude convention of the file's amplitudes.
    phase : {"lag", "lead"}
        The phase convention: a lag (the analysers' usual) is the rotation from the key-phasor pulse to the
        probe's peak.
    speed_unit : str, optional
        The unit of the speed column when its header carries none (a header named in ``columns``).
    slow_roll : (float, float), optional
        Speed range in rad/s whose mean 1x vector (the run-out) is subtracted from every vector.
    columns : dict, optional
        Quantity -> header of its column, e.g. ``{"speed": "Drehzahl (rpm)"}``; other columns skipped.

    Returns
    -------
    OneX
        Speeds strictly monotonic in the file's order (a run-up rising, a coast-down falling).
    """
    _conventions(amplitude, phase)
    table = _Table(path, columns, folder, _vector_kind, _EXAMPLE, MAX_POINTS)
    p, notes = table.path, []
    if "speed" not in table.values:
        raise ScenarioError(f"{p}: no speed column; add 'speed [rpm]' (or Hz, rad/s)")
    unit = table.units["speed"]
    if speed_unit is not None:
        factor = table._factor("speed", speed_unit, "angular speed")
        if unit.strip() in ("1", "-", ""):
            table.values["speed"] = table.values["speed"] * factor
            unit = speed_unit
        elif not math.isclose(table._factor("speed", unit, "angular speed"), factor):
            raise ScenarioError(f"{p}: column 'speed [{unit}]' is in {unit}, speed_unit says {speed_unit}; "
                                f"correct one of them")
    elif unit.strip() in ("1", "-", ""):
        raise ScenarioError(f"{p}: column 'speed [{unit}]': a speed has a unit: write rpm, Hz or rad/s")
    vectors = {}
    for probe in ("x", "y"):
        amp, ph = _probe_column(table, "amplitude", probe), _probe_column(table, "phase", probe)
        if amp is None and ph is None and probe == "y":
            continue
        for col, what in ((amp, "amplitude"), (ph, "phase")):
            if col is None:
                other = amp or ph
                raise ScenarioError(f"{p}: column '{other[0]} [{table.units[other[0]]}]' has no {what} column of "
                                    f"probe {probe} beside it; add '{what}{'_y' if probe == 'y' else ''} "
                                    f"[{'um' if what == 'amplitude' else 'deg'}]'")
            said = _CONVENTION.get(col[1])
            given = amplitude if what == "amplitude" else phase
            if said is not None and said != given:
                raise ScenarioError(f"{p}: column '{col[0]} [{table.units[col[0]]}]' is {said}, the scene says "
                                    f"{what}: {given}; correct one of them")
        a, theta = table.values[amp[0]], table.values[ph[0]]
        if (a < 0).any():
            i = int(np.argmax(a < 0))
            raise ScenarioError(f"{p}: line {table.line(i)}, column '{amp[0]} [{table.units[amp[0]]}]': an amplitude "
                                f"must not be negative, got {a[i] * 1e6:g} µm")
        notes += _phase_notes(table, ph[0], theta, a)
        sign = -1 if phase == "lag" else 1
        vectors[probe] = (0.5 if amplitude == "peak-to-peak" else 1.0) * a * np.exp(sign * 1j * theta)
    halved = " halved to 0-peak" if amplitude == "peak-to-peak" else ""
    notes.insert(0, f"speed from {unit}; amplitude {amplitude}{halved}; phase {phase} from the key-phasor: "
                    f"X = A exp({'-' if phase == 'lag' else '+'}i phase)")
    speed, time = table.values["speed"], table.values.get("time")
    _check_order(table, speed, time)
    return _finish(OneX(speed=speed, x=vectors["x"], y=vectors.get("y"), time=time, path=str(p), notes=tuple(notes)),
                   slow_roll)


def _phase_notes(table: _Table, name: str, theta: np.ndarray, amp: np.ndarray) -> list[str]:
    """The unwrapping of a phase column (notes); a step no wrap explains refused."""
    p, deg = table.path, np.degrees(theta)
    unwrapped = np.unwrap(deg, period=360.0)
    turns = np.round((unwrapped - deg) / 360.0)
    at = np.flatnonzero(np.diff(turns)) + 1
    notes = []
    if at.size:
        band = "0-360°" if deg.min() >= 0 else "±180°"
        notes.append(f"{name}: wrapped by the analyser at {band}: {at.size} step(s) of 360° unwrapped (line(s) "
                     f"{', '.join(str(table.line(i)) for i in at[:5])}{', ...' if at.size > 5 else ''}); the vectors "
                     f"are unchanged")
    step = np.diff(unwrapped)
    above = amp >= PHASE_FLOOR * amp.max()
    bad = (np.abs(step) > MAX_PHASE_STEP) & above[1:] & above[:-1]
    if bad.any():
        i = int(np.argmax(bad))
        speed = table.values["speed"]
        raise ScenarioError(f"{p}: line {table.line(i + 1)}, column '{name} [{table.units[name]}]': the phase turns by "
                            f"{step[i]:+.0f}° from line {table.line(i)} ({_rpm(speed[i])} to {_rpm(speed[i + 1])}), "
                            f"more than {MAX_PHASE_STEP:.0f}° between neighbouring vectors, and no wrap of 360° "
                            f"explains it: a key-phasor slip, a probe's sign, or speed steps too coarse for the "
                            f"resonance")
    if np.abs(deg).max() <= 2 * math.pi + 0.01 and table.units[name].strip() != "rad":
        notes.append(f"{name}: every phase lies within ±6.3°: if the column holds radians, head it '{name} [rad]'")
    return notes


def _check_order(table: _Table, speed: np.ndarray, time: np.ndarray | None) -> None:
    """Refuse time stamps that do not rise, a speed that is not positive, repeats, reverses or is out of order."""
    p = table.path
    if time is not None and (np.diff(time) <= 0).any():
        i = int(np.argmax(np.diff(time) <= 0))
        raise ScenarioError(f"{p}: line {table.line(i + 1)}, column 'time [{table.units['time']}]': the time does not "
                            f"rise from line {table.line(i)}; the rows are in time order")
    if (speed <= 0).any():
        i = int(np.argmax(speed <= 0))
        raise ScenarioError(f"{p}: line {table.line(i)}, column 'speed [{table.units['speed']}]': a speed must be "
                            f"positive, got {speed[i]:g} rad/s")
    d = np.diff(speed)
    if (d == 0).any():
        i = int(np.argmax(d == 0))
        raise ScenarioError(f"{p}: line {table.line(i + 1)}, column 'speed [{table.units['speed']}]': the speed "
                            f"{_rpm(speed[i])} repeats line {table.line(i)}; one vector per speed (average the "
                            f"repeats, or drop them)")
    turns = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1])) + 1
    if turns.size == 1:
        i = int(turns[0])
        rise = "rises" if d[0] > 0 else "falls"
        raise ScenarioError(f"{p}: line {table.line(i)}, column 'speed [{table.units['speed']}]': the speed {rise} to "
                            f"{_rpm(speed[i])} and then turns: a run-up and a coast-down in one file; give each a file "
                            f"of its own")
    if turns.size:
        i = int(turns[0])
        raise ScenarioError(f"{p}: line {table.line(i + 1)}, column 'speed [{table.units['speed']}]': speeds out of "
                            f"order ({_rpm(speed[i + 1])} after {_rpm(speed[i])}); the rows of a run-up are in time "
                            f"order, the speed rising (of a coast-down, falling)")


def _finish(one: OneX, slow_roll) -> OneX:
    """The slow-roll run-out subtracted (noted) and too few vectors refused."""
    p = one.path or "1x vectors"
    if len(one.speed) < MIN_VECTORS:
        raise ScenarioError(f"{p}: {len(one.speed)} vectors; a run-up needs at least {MIN_VECTORS}")
    if slow_roll is None:
        return one
    try:
        low, high = (float(v) for v in slow_roll)
    except (TypeError, ValueError):
        raise ScenarioError(f"slow_roll: {slow_roll!r} is no speed range: give (low, high) in rad/s") from None
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
        raise ScenarioError(f"slow_roll: ({low:g}, {high:g}) rad/s is no speed range: 0 <= low < high")
    inside = (one.speed >= low) & (one.speed <= high)
    if not inside.any():
        raise ScenarioError(f"slow_roll: no vector of {p} between {_rpm(low)} and {_rpm(high)} ({low:g} to {high:g} "
                            f"rad/s); its speeds run from {_rpm(one.speed.min())} to {_rpm(one.speed.max())}")
    notes, probes = list(one.notes), {}
    for probe in ("x", "y"):
        v = getattr(one, probe)
        if v is not None:
            runout = v[inside].mean()
            probes[probe] = v - runout
            notes.append(f"slow-roll run-out subtracted from probe {probe}: {_um(runout)} (0-peak; the mean of "
                         f"{inside.sum()} vector(s) from {_rpm(one.speed[inside].min())} to "
                         f"{_rpm(one.speed[inside].max())})")
    return OneX(speed=one.speed, x=probes["x"], y=probes.get("y"), time=one.time, path=one.path, notes=tuple(notes))
