"""A measured run-up or coast-down read into 1x vectors (`OneX`), in SI and the toolkit's conventions.

Two kinds of file are read, both CSV texts whose header cells read `quantity [unit]` (as the rig files of
`autobal.measurements`: `#` comment lines, UTF-8 with or without a byte-order mark, ',' or, in a
spreadsheet export, ';' with decimal commas; `columns` names the columns to take by their headers, others
skipped, e.g. `{"speed": "Drehzahl (rpm)", "amplitude": "Amplitude (µm)", "phase": "Phase (°)"}`).

**1x vectors** (`read_vectors`), one row per vector as a vibration analyser exports them, in time order:

| header | unit | meaning |
|---|---|---|
| `speed` | rpm, r/min, 1/min, Hz, rad/s | shaft speed (required) |
| `time` | s, ms | time stamp (optional; it must rise) |
| `amplitude` (or `amplitude_x`) | µm (um), mm, m | 1x amplitude of probe x (required) |
| `phase` (or `phase_x`) | deg (°), rad | 1x phase of probe x from the key-phasor (required) |
| `amplitude_y`, `phase_y` | as above | probe y, 90° from x in the direction of rotation (optional, both or neither) |

The conventions are the caller's (the scene's): `amplitude` "0-peak" or "peak-to-peak", `phase` "lag" or
"lead".  A header may state its own with a suffix: `amplitude_pp` / `amplitude_0p` (`amplitude_x_pp`,
`amplitude_y_0p`, ...) and `phase_lag` / `phase_lead` (`phase_y_lag`, ...); a suffix that contradicts the
caller's convention is refused, never converted twice.  A speed header without a unit (a column named in
`columns`) takes `speed_unit`.

**Raw signals** (`read_signals`), one row per sample, in a file of at most 20 MB (about 500 000 samples of
four channels: cut the record to the run-up, or decimate it to some 50 samples a revolution at the top speed):

| header | unit | meaning |
|---|---|---|
| `time` | s, ms | sample time (required, rising) |
| `probe_x` | µm (um), mm, m | displacement of probe x (required) |
| `probe_y` | µm (um), mm, m | displacement of probe y, 90° from x in the direction of rotation (optional) |
| `keyphasor` | V, mV or 1 | once-per-turn pulse: a voltage or a 0/1 channel |
| `speed` | rpm, Hz, rad/s | shaft speed (a tachometer): the angle when there is no `keyphasor`, else a cross-check |

Conventions of the result: `x(t) = Re(X exp(i phi(t)))` with `X` the complex 0-peak 1x amplitude in m and
`phi` the shaft angle since the key-phasor pulse (0 at the pulse), positive in the direction of rotation.
An analyser's phase lag `theta` (the probe's peak comes `theta` degrees of rotation after the pulse) is
`X = A exp(-i theta)`; a phase lead is `X = A exp(+i theta)`.

What the reading does, each step stated in `OneX.notes`:

- units from the headers to SI; a peak-to-peak amplitude halved; the phase turned into the convention above;
- a phase wrapped by the analyser at ±180° or 0-360° is unwrapped (a step of 360° is a wrap; the vector
  itself does not change); a step that no multiple of 360° explains, of more than `MAX_PHASE_STEP`
  between neighbouring vectors that stand above the noise, is refused (a key-phasor slip, a sign change, or
  a phase turn the speed steps do not resolve);
- `slow_roll=(low, high)` in rad/s: the mean 1x vector of the vectors in that speed range (the run-out and
  electrical run-out of the probe track) is subtracted from every vector of its probe;
- raw signals: order tracking per revolution.  The key-phasor's two levels are found from the channel (the
  medians either side of its mid-range), the pulses are the edges through the level halfway between them (with
  hysteresis of a quarter of the step), interpolated between samples: rising edges (a projection), or falling
  ones when the channel is high for more than 1-`NOTCH` of the time (a notch).  The shaft angle over a revolution
  is a quadratic in time fitted by least squares to the angles 2 pi k at the `FIT_PULSES` pulses around it: exact
  for a constant acceleration (linear interpolation between two pulses errs by up to alpha T^2/8) and it averages
  the timing error of a sampled pulse edge (up to half a sample, which makes 2 pi/T jitter by dt/T, more than a
  run-up's change of speed from one revolution to the next); a sudden change of the acceleration by d_alpha (a
  drive switched from a hold to a ramp) is smoothed over those pulses, the speed off by up to d_alpha T within
  `FIT_PULSES`/2 revolutions of it.  The revolution's 1x vector is the least squares fit of an offset, 1x and 2x
  to its samples at their angles (the revolution's DFT where the samples are uniform in angle; exact for these
  harmonics wherever the samples fall; at least `MIN_SAMPLES` samples a revolution), at the fitted speed and the
  time of the revolution's middle.  A revolution `LONG_REVOLUTION` times the median of its nearest whole
  neighbours or more missed a pulse: dropped and noted, and the turns it missed counted (more than `MAX_MISSED`
  of them: refused); one that much shorter is a spurious pulse: refused.  The period may change by up to about 10
  % a revolution (2 pi alpha/omega^2 < 0.1) for these tests to hold.  A key-phasor and a speed channel together
  must agree within 2 %.  Without a key-phasor the speed channel is integrated to the angle, whose zero (the
  first sample) is arbitrary: the phase is then relative, and an error of the speed channel drifts it.
  Revolutions whose speed dithers on a plateau (within `DITHER` of the run's extreme so far) are dropped so that
  the speed is strictly monotonic.

Refused, each with one line naming the file, the line or column and the unit (`ScenarioError`): an empty
cell or a NaN, a negative amplitude, a speed that is not positive, a repeated speed, speeds out of order or a
run-up and a coast-down in one file (one file, one direction), time stamps that do not rise, a header that
contradicts the caller's convention or unit, fewer than `MIN_VECTORS` vectors, no key-phasor and no
speed channel, a constant key-phasor, too few samples a revolution, a slow-roll range that holds no vector.

Not detectable, so not checked: a phase column written in radians but headed `[deg]` (values within ±6.3
are possible phases in degrees; a note says so when every phase lies in that band), a probe y mounted against
the direction of rotation (its vectors come out mirrored), an amplitude convention mislabelled by the analyser
itself, and a key-phasor that misses every other pulse without a speed channel beside it (every revolution
alike twice as long: the speeds come out halved).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from autobal.errors import ScenarioError
from autobal.measurements import MAX_POINTS, read_table
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
FIT_PULSES = 8  # key-phasor pulses around a revolution fitted by its shaft angle (seven revolutions)
NOTCH = 0.35  # a key-phasor high for more than 1 - NOTCH of the time is a notch (its falling edges are the marks)
MIN_SAMPLES = 8  # samples per revolution: offset, 1x and 2x are fitted (5 unknowns); 3x and above alias
MAX_SAMPLES = 2_000_000  # rows of a raw-signal file (the 20 MB of autobal.measurements.MAX_DATA_BYTES bind first)
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

    def __init__(self, path, columns, folder, kinds, example, max_rows, given=None):
        table = read_table(path, columns, folder, where="columns", example=example)
        self.path = table.path
        self.values, self.units = {}, {}
        for j, name, unit in table.selected:
            kind = kinds(name)
            if kind is None:
                raise ScenarioError(f"{self.path}: column {j + 1}: unknown quantity {name!r}; expected e.g. "
                                    f"'{example}' (the formats: autobal.runup_data)")
            if name in self.units:
                raise ScenarioError(f"{self.path}: column {name!r} appears twice")
            if (given or {}).get(name) is not None:  # the unit given apart: for a header without one
                if unit.strip() in ("1", "-", ""):
                    unit = given[name]
                elif not math.isclose(self._factor(name, unit, kind), self._factor(name, given[name], kind)):
                    raise ScenarioError(f"{self.path}: column '{name} [{unit}]' is in {unit}, {name}_unit says "
                                        f"{given[name]}; correct one of them")
            self.units[name] = unit
            self.values[name] = self._factor(name, unit, kind)  # the SI factor, until the rows are read
        table.check_rows(max_rows)
        self.lines = np.array(table.lines)
        for j, name, _ in table.selected:
            self.values[name] = table.numbers(j, f"{name} [{self.units[name]}]", "label") * self.values[name]

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
            raise ScenarioError(f"{self.path}: column {cell}: {exc}") from None

    def line(self, i: int) -> int:
        return int(self.lines[i])

    def rising_time(self, rows: str) -> None:
        """Refuse a time column that does not rise from row to row (``rows``: what the rows are)."""
        time = self.values.get("time")
        if time is not None and (np.diff(time) <= 0).any():
            i = int(np.argmax(np.diff(time) <= 0))
            raise ScenarioError(f"{self.path}: line {self.line(i + 1)}, column 'time [{self.units['time']}]': the time "
                                f"does not rise from line {self.line(i)}; the {rows} are in time order")


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
    table = _Table(path, columns, folder, _vector_kind, _EXAMPLE, MAX_POINTS, given={"speed": speed_unit})
    p, notes = table.path, []
    if "speed" not in table.values:
        raise ScenarioError(f"{p}: no speed column; add 'speed [rpm]' (or Hz, rad/s)")
    unit = table.units["speed"]
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
    _check_order(table, speed)
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


def _check_order(table: _Table, speed: np.ndarray) -> None:
    """Refuse time stamps that do not rise, a speed that is not positive, repeats, reverses or is out of order."""
    p = table.path
    table.rising_time("rows")
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
    changes = np.flatnonzero(np.sign(d[1:]) != np.sign(d[:-1])) + 1
    if changes.size == 1:
        i = int(changes[0])
        rise = "rises" if d[0] > 0 else "falls"
        raise ScenarioError(f"{p}: line {table.line(i)}, column 'speed [{table.units['speed']}]': the speed {rise} to "
                            f"{_rpm(speed[i])} and then turns: a run-up and a coast-down in one file; give each a file "
                            f"of its own")
    if changes.size:
        i = int(changes[0])
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


def read_signals(path, *, slow_roll=None, columns: dict | None = None, folder=None) -> OneX:
    """Read a CSV of raw signals (time, probe x, optionally probe y, a key-phasor or a speed channel) and
    extract the 1x vectors by order tracking, one per revolution (the method in the module docstring).

    Parameters
    ----------
    path : str or Path
        The file: absolute, or relative to ``folder`` (the scene file's folder; default the working folder).
    slow_roll : (float, float), optional
        Speed range in rad/s whose mean 1x vector (the run-out) is subtracted from every vector.
    columns : dict, optional
        Quantity -> header of its column, e.g. ``{"time": "t (s)", "probe_x": "Weg x (µm)"}``.

    Returns
    -------
    OneX
        One vector per whole revolution at the speed of the fitted shaft angle and the time of the
        revolution's middle, speeds strictly monotonic.
    """
    table = _Table(path, columns, folder, _signal_kind, _SIGNAL_EXAMPLE, MAX_SAMPLES)
    p, v, notes = table.path, table.values, []
    for need in ("time", "probe_x"):
        if need not in v:
            raise ScenarioError(f"{p}: no {need} column; add '{need} [{'s' if need == 'time' else 'um'}]'")
    t = v["time"]
    table.rising_time("samples")
    if "keyphasor" in v:
        pulses, how = _pulses(table)
        keep, turns = _whole_revolutions(table, pulses)
        missed = int((~keep).sum())
        notes.append(how + (f"; {missed} revolution(s) with a missed pulse dropped (the turns it missed counted)"
                            if missed else ""))
    elif "speed" in v:
        speed = v["speed"]
        if (speed < 0).any():
            i = int(np.argmax(speed < 0))
            raise ScenarioError(f"{p}: line {table.line(i)}, column 'speed [{table.units['speed']}]': a speed must "
                                f"not be negative, got {speed[i]:g} rad/s")
        angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))))
        pulses = np.interp(2 * math.pi * np.arange(int(angle[-1] / (2 * math.pi)) + 1), angle, t)
        keep, turns = np.ones(max(len(pulses) - 1, 0), bool), np.ones(max(len(pulses) - 1, 0))
        notes.append(f"no key-phasor: the speed channel integrated to the shaft angle, zero at the first sample "
                     f"(t = {t[0]:g} s); the phase is relative to that arbitrary zero, and an error of the speed "
                     f"channel drifts it (0.36° per revolution for each 0.1 % of speed)")
    else:
        raise ScenarioError(f"{p}: no key-phasor and no speed channel: add 'keyphasor [V]' (a once-per-turn "
                            f"pulse) or 'speed [rpm]'")
    if keep.sum() < MIN_VECTORS:
        raise ScenarioError(f"{p}: {keep.sum()} whole revolution(s) in the record; order tracking needs at least "
                            f"{MIN_VECTORS}")
    fit = _angle_fit(pulses, 2 * math.pi * np.concatenate(([0], np.cumsum(turns))))
    probes = {probe: _track(table, t, v[f"probe_{probe}"], pulses, fit, keep)
              for probe in ("x", "y") if f"probe_{probe}" in v}
    time = (pulses[:-1] + 0.5 * np.diff(pulses))[keep]
    speed = fit[keep, 1]
    if "keyphasor" in v and "speed" in v:
        notes.append(_agree(table, speed, np.interp(time, t, v["speed"])))
    mono = _monotonic(table, speed, time)
    if not mono.all():
        notes.append(f"{(~mono).sum()} revolution(s) whose speed dithers within {DITHER:.0%} of the run's "
                     f"extreme so far dropped (the speeds are strictly monotonic)")
    notes.append(f"order tracking: {mono.sum()} revolutions from {_rpm(speed[mono][0])} to "
                 f"{_rpm(speed[mono][-1])}; probe(s) {', '.join(probes)} from {table.units['probe_x']}")
    one = OneX(speed=speed[mono], x=probes["x"][mono], y=probes["y"][mono] if "y" in probes else None,
               time=time[mono], path=str(p), notes=tuple(notes))
    return _finish(one, slow_roll)


def _angle_fit(pulses: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """The shaft angle about the middle ``tm`` of each revolution, ``a + b (t - tm) + c (t - tm)^2``, fitted by
    least squares to the angles at the `FIT_PULSES` pulses around it (``[a, b, c]`` per revolution, ``b``
    its speed): exact for a constant acceleration, and it averages the timing error of a sampled pulse edge
    (up to half a sample) that makes ``2 pi / T`` jitter by ``dt / T``."""
    n, m = len(pulses) - 1, min(FIT_PULSES, len(pulses))
    first = np.clip(np.arange(n) - m // 2 + 1, 0, len(pulses) - m)
    window = first[:, None] + np.arange(m)
    mid = pulses[:-1] + 0.5 * np.diff(pulses)
    scale = np.diff(pulses)[:, None]  # tau in periods keeps the normal equations well scaled
    tau = (pulses[window] - mid[:, None]) / scale
    basis = np.stack([np.ones_like(tau), tau, tau**2], axis=2)
    normal = np.einsum("kia,kib->kab", basis, basis)
    rhs = np.einsum("kia,ki->ka", basis, angle[window])
    c = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
    return c / np.column_stack((np.ones(n), scale[:, 0], scale[:, 0] ** 2))


def _pulses(table: _Table) -> tuple[np.ndarray, str]:
    """The times of the key-phasor pulses (the leading edges of the rarer state) and a note saying how."""
    p, t, k = table.path, table.values["time"], table.values["keyphasor"]
    lo, hi = k.min(), k.max()
    if not hi > lo:
        raise ScenarioError(f"{p}: column 'keyphasor [{table.units['keyphasor']}]' is constant ({lo:g}): no pulses")
    low, high = np.median(k[k <= 0.5 * (lo + hi)]), np.median(k[k > 0.5 * (lo + hi)])
    mid = 0.5 * (low + high)
    duty = (k > mid).mean()
    notch = duty > 1 - NOTCH  # the pulse is the rarer state: a notch is low for a short part of a turn
    w, level = (-k, -mid) if notch else (k, mid)
    above = w > level
    cand = np.flatnonzero(~above[:-1] & above[1:]) + 1  # first sample past the level
    # hysteresis: an edge counts when the channel was back below the level by a quarter of the step since the
    # last one (noise on the edge does not make a second pulse)
    below = np.concatenate(([0], np.cumsum(w < level - 0.25 * (high - low))))  # below[i]: in samples 0..i-1
    since = np.concatenate(([0], cand[:-1] + 1))
    fire = cand[below[cand] - below[since] > 0]
    t0, t1 = t[fire - 1], t[fire]
    pulses = t0 + (level - w[fire - 1]) / (w[fire] - w[fire - 1]) * (t1 - t0)
    edge = "falling edges (a notch)" if notch else "rising edges"
    if NOTCH <= duty <= 1 - NOTCH:
        edge += f" (the channel is high {duty:.0%} of the time: neither state is a short pulse, its rising edge taken)"
    unit = table.units["keyphasor"]
    return pulses, (f"key-phasor: {len(pulses)} pulses, {edge} through {mid:.3g} {unit} (halfway between its levels "
                    f"{low:.3g} and {high:.3g} {unit})")


def _near(good: np.ndarray, k: int) -> np.ndarray:
    """The (up to) four revolutions of ``good`` nearest to ``k``, two on each side where there are."""
    g = good[good != k]
    pos = int(np.searchsorted(g, k))
    left, right = g[max(0, pos - 2):pos], g[pos:pos + 2]
    if len(left) < 2:
        right = g[pos:pos + 4 - len(left)]
    if len(right) < 2:
        left = g[max(0, pos - 4 + len(right)):pos]
    return np.concatenate((left, right))


def _whole_revolutions(table: _Table, pulses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which revolutions between key-phasor pulses are whole (a missed pulse makes one
    `LONG_REVOLUTION` times the median of its nearest whole neighbours or more), and the turns between
    each two pulses (that ratio rounded where a pulse was missed, else 1); a spurious pulse (a revolution that
    much shorter) and too many missed pulses are refused."""
    p, period = table.path, np.diff(pulses)
    n = len(period)
    missed = np.zeros(n, bool)
    while n >= 3:
        good = np.flatnonzero(~missed)
        new = missed.copy()
        for k in good:
            new[k] = period[k] > LONG_REVOLUTION * np.median(period[_near(good, k)])
        if (new == missed).all():
            break
        missed = new
    good = np.flatnonzero(~missed)
    for k in good if len(good) >= 3 else ():
        typical = np.median(period[_near(good, k)])
        if period[k] * LONG_REVOLUTION < typical:
            raise ScenarioError(f"{p}: column 'keyphasor [{table.units['keyphasor']}]': the revolution from t = "
                                f"{pulses[k]:.6g} s lasts "
                                f"{period[k] / typical:.2f} of its neighbours: a spurious pulse (noise, a second mark "
                                f"on the shaft); clean the channel")
    if missed.sum() > MAX_MISSED * n:
        raise ScenarioError(f"{p}: column 'keyphasor [{table.units['keyphasor']}]': {missed.sum()} of {n} revolutions "
                            f"miss a pulse (more than {MAX_MISSED:.0%}): the key-phasor is unreliable; check its "
                            f"gap and threshold, or give a speed channel instead")
    turns = np.ones(n)
    for k in np.flatnonzero(missed):
        turns[k] = max(2, round(period[k] / np.median(period[_near(good, k)])))
    return ~missed, turns


def _track(table: _Table, t: np.ndarray, x: np.ndarray, pulses: np.ndarray, fit: np.ndarray,
           keep: np.ndarray) -> np.ndarray:
    """The 1x vector of ``x`` over each kept revolution between ``pulses``: offset, 1x and 2x fitted by least
    squares to the samples at their shaft angle (from ``fit``, :func:`_angle_fit`): the revolution's DFT where
    the samples are uniform in angle, and exact for these harmonics wherever the samples fall."""
    first = np.searchsorted(t, pulses, side="left")  # revolution k: samples first[k] .. first[k + 1] - 1
    count = np.diff(first)
    if (count < MIN_SAMPLES).any():
        k = int(np.argmax(count < MIN_SAMPLES))
        raise ScenarioError(f"{table.path}: column 'time [{table.units['time']}]': the revolution from t = "
                            f"{pulses[k]:.6g} s ({_rpm(2 * math.pi / (pulses[k + 1] - pulses[k]))}) holds {count[k]} "
                            f"sample(s); order tracking needs at least {MIN_SAMPLES} per revolution: sample faster")
    span = slice(first[0], first[-1])
    rev = np.repeat(np.arange(len(count)), count)
    tau = t[span] - (pulses[:-1] + 0.5 * np.diff(pulses))[rev]
    phi = fit[rev, 0] + tau * (fit[rev, 1] + tau * fit[rev, 2])
    basis = np.array([np.ones_like(phi), np.cos(phi), np.sin(phi), np.cos(2 * phi), np.sin(2 * phi)])
    starts = first[:-1] - first[0]
    normal = np.empty((len(starts), 5, 5))
    for a in range(5):
        for b in range(a, 5):
            normal[:, a, b] = normal[:, b, a] = np.add.reduceat(basis[a] * basis[b], starts)
    rhs = np.add.reduceat(basis * x[span], starts, axis=1).T
    c = np.linalg.solve(normal[keep], rhs[keep][:, :, None])[:, :, 0]
    return c[:, 1] - 1j * c[:, 2]  # x = c1 cos(phi) + c2 sin(phi) = Re((c1 - i c2) exp(i phi))


def _agree(table: _Table, tracked: np.ndarray, channel: np.ndarray) -> str:
    """The key-phasor's speeds against the speed channel's: a note when they agree, refused when not (a pulse
    missed every turn, two marks on the shaft, a wrong unit)."""
    ratio = float(np.median(tracked / channel))
    if abs(ratio - 1) > 0.02:
        raise ScenarioError(f"{table.path}: the key-phasor gives {ratio:.3g} times the speed of column "
                            f"'speed [{table.units['speed']}]': a pulse missed each turn, two marks on the shaft, or "
                            f"the speed's unit; correct the channel or leave one out")
    return f"the speed channel agrees with the key-phasor within {abs(ratio - 1):.2%} (median); the key-phasor is used"


def _monotonic(table: _Table, speed: np.ndarray, time: np.ndarray) -> np.ndarray:
    """The revolutions that extend the run strictly (a run-up rising, a coast-down falling); a fall from the
    run's extreme of more than `DITHER` is a reversal, refused."""
    up = speed[-1] > speed[0]
    extreme = (np.maximum if up else np.minimum).accumulate(speed)
    before = np.concatenate(([-np.inf if up else np.inf], extreme[:-1]))
    keep = speed > before if up else speed < before
    turned = speed < (1 - DITHER) * before if up else speed > (1 + DITHER) * before
    if turned.any():
        i = int(np.argmax(turned))
        raise ScenarioError(f"{table.path}: at t = {time[i]:.6g} s the speed turns from {_rpm(before[i])} back to "
                            f"{_rpm(speed[i])}: a run-up and a coast-down in one record; give each a file of its own")
    return keep
