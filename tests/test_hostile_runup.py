"""Bad run-up measurements (autobal/runup_data.py): each refused with one line naming the file, the line or the
column and the unit, or read with the limitation stated in the notes; never a confident wrong answer."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from autobal.errors import ScenarioError
from autobal.runup_data import read_signals, read_vectors
from tests.test_runup_data import write_signals

RPM = 2 * math.pi / 60
HEAD = "speed [rpm],amplitude [um],phase [deg]"
SPEEDS = list(range(1000, 2000, 100))  # ten vectors
AMPS = [2, 3, 4, 6, 10, 20, 12, 8, 6, 5]
PHASES = [5, 8, 12, 20, 35, 90, 140, 160, 168, 172]


def csv(tmp_path, rows, head=HEAD, name="v.csv"):
    f = tmp_path / name
    f.write_text(head + "\n" + "\n".join(",".join(str(c) for c in r) for r in rows) + "\n")
    return f


def table(speeds=SPEEDS, amps=AMPS, phases=PHASES):
    return list(zip(speeds, amps, phases, strict=True))


def refused(call, *parts):
    """``call`` raises a one-line ScenarioError holding every one of ``parts``; returned."""
    with pytest.raises(ScenarioError) as info:
        call()
    message = str(info.value)
    assert "\n" not in message, message
    for part in parts:
        assert part in message, message
    return message


def vectors(path, **kw):
    return lambda: read_vectors(path, **{"amplitude": "0-peak", "phase": "lag", **kw})


# ---- 1x vector files ------------------------------------------------------------------------------------------

def test_unsorted_speeds(tmp_path):
    f = csv(tmp_path, table(speeds=[1000, 1100, 1300, 1200, 1400, 1500, 1600, 1700, 1800, 1900]))
    refused(vectors(f), "v.csv: line 5, column 'speed [rpm]'", "speeds out of order (1200 rpm after 1300 rpm)")


def test_repeated_speeds(tmp_path):
    f = csv(tmp_path, table(speeds=[1000, 1100, 1100, 1200, 1300, 1400, 1500, 1600, 1700, 1800]))
    refused(vectors(f), "line 4, column 'speed [rpm]'", "1100 rpm repeats line 3")


def test_a_run_up_and_a_coast_down_in_one_file(tmp_path):
    f = csv(tmp_path, table(speeds=[1000, 1200, 1400, 1600, 1800, 2000, 1900, 1700, 1500, 1300]))
    refused(vectors(f), "line 7", "rises to 2000 rpm and then turns: a run-up and a coast-down in one file")


def test_time_stamps_that_do_not_rise(tmp_path):
    rows = [(s, t, a, p) for s, t, a, p in zip(SPEEDS, [0, 1, 2, 3, 3, 5, 6, 7, 8, 9], AMPS, PHASES, strict=True)]
    f = csv(tmp_path, rows, head="speed [rpm],time [s],amplitude [um],phase [deg]")
    refused(vectors(f), "line 6, column 'time [s]': the time does not rise from line 5")


def test_phase_wrapped_at_180_is_unwrapped_and_noted(tmp_path):
    """A 360° jump is a wrap: the same vectors as the unwrapped phases, and the notes say where."""
    wrapped = [((p + 180) % 360) - 180 for p in np.array(PHASES) + 60]  # 65 ... 232 -> ... -128
    plain = read_vectors(csv(tmp_path, table(phases=list(np.array(PHASES) + 60)), name="a.csv"),
                         amplitude="0-peak", phase="lag")
    one = read_vectors(csv(tmp_path, table(phases=wrapped), name="b.csv"), amplitude="0-peak", phase="lag")
    assert_allclose(one.x, plain.x, rtol=1e-12)
    assert any("wrapped by the analyser at ±180°: 1 step(s) of 360° unwrapped (line(s) 8)" in n for n in one.notes)


def test_a_phase_jump_no_wrap_explains(tmp_path):
    f = csv(tmp_path, table(amps=[10] * 10, phases=[5, 8, 12, 15, 150, 153, 156, 158, 160, 161]))
    refused(vectors(f), "line 6, column 'phase [deg]': the phase turns by +135° from line 5 (1300 rpm to 1400 rpm)",
            "no wrap of 360° explains it")


def test_phase_noise_of_vectors_in_the_noise_is_no_jump(tmp_path):
    """At slow roll the vectors are tiny and their phase random: steps there are not checked."""
    f = csv(tmp_path, table(amps=[0.2, 0.3, 0.2, 6, 10, 20, 12, 8, 6, 5],
                            phases=[170, -60, 100, 20, 35, 90, 140, 160, 168, 172]))
    assert len(read_vectors(f, amplitude="0-peak", phase="lag").speed) == 10


@pytest.mark.parametrize("head, caller, says", [
    ("speed [rpm],amplitude_pp [um],phase [deg]", {"amplitude": "0-peak"}, "'amplitude_pp [um]' is peak-to-peak, "
     "the scene says amplitude: 0-peak"),
    ("speed [rpm],amplitude_0p [um],phase [deg]", {"amplitude": "peak-to-peak"}, "'amplitude_0p [um]' is 0-peak"),
    ("speed [rpm],amplitude [um],phase_lead [deg]", {"phase": "lag"}, "'phase_lead [deg]' is lead, the scene says "
     "phase: lag"),
])
def test_mixed_conventions_are_refused(tmp_path, head, caller, says):
    refused(vectors(csv(tmp_path, table(), head=head), **caller), says, "correct one of them")


@pytest.mark.parametrize("kw, says", [
    ({"amplitude": "rms"}, "amplitude: 'rms' is no amplitude convention: write '0-peak' or 'peak-to-peak'"),
    ({"phase": "degrees"}, "phase: 'degrees' is no phase convention: write 'lag' or 'lead'"),
])
def test_unknown_conventions(tmp_path, kw, says):
    refused(vectors(csv(tmp_path, table()), **kw), says)


@pytest.mark.parametrize("cell, says", [("nan", "'nan' is not a finite number"), ("", "'' is not a number"),
                                        ("-3", "an amplitude must not be negative, got -3 µm")])
def test_nan_empty_and_negative_amplitudes(tmp_path, cell, says):
    rows = table()
    rows[4] = (rows[4][0], cell, rows[4][2])
    refused(vectors(csv(tmp_path, rows)), "line 6, column 'amplitude [um]'", says)


def test_an_empty_row_of_a_spreadsheet_is_skipped_but_a_row_of_empty_cells_with_a_number_is_not(tmp_path):
    rows = [",".join(map(str, r)) for r in table()]
    f = tmp_path / "v.csv"
    f.write_text(HEAD + "\n" + "\n".join(rows[:5] + [",,"] + rows[5:]) + "\n")
    assert len(read_vectors(f, amplitude="0-peak", phase="lag").speed) == 10
    f.write_text(HEAD + "\n" + "\n".join(rows[:5] + ["1550,,"] + rows[5:]) + "\n")
    refused(vectors(f), "line 7, column 'amplitude [um]': '' is not a number")


def test_radians_in_a_degree_column_cannot_be_told_and_the_notes_say_so(tmp_path):
    one = read_vectors(csv(tmp_path, table(phases=[0.1, 0.2, 0.3, 0.5, 0.8, 1.5, 2.4, 2.8, 2.9, 3.0])),
                       amplitude="0-peak", phase="lag")
    assert any("every phase lies within ±6.3°: if the column holds radians, head it 'phase [rad]'" in n
               for n in one.notes)


def test_too_few_vectors(tmp_path):
    refused(vectors(csv(tmp_path, table()[:4])), "v.csv: 4 vectors; a run-up needs at least 5")


@pytest.mark.parametrize("head, says", [
    ("speed [1/s],amplitude [um],phase [deg]", "column 'speed [1/s]': '1/s' is ambiguous for an angular speed"),
    ("speed [rpm],amplitude [V],phase [deg]", "column 'amplitude [V]': 'V' is not a length unit"),
    ("speed [rpm],amplitude [um],phase [grad]", "column 'phase [grad]': 'grad' is not a unit of a phase: write deg"),
    ("speed [rpm],amplitude [um],phase_x_pp [deg]", "unknown quantity 'phase_x_pp'"),
    ("speed [rpm],amplitude [um],amplitude_x [um]", "columns 'amplitude' and 'amplitude_x' both give the amplitude "
     "of probe x"),
    ("speed [rpm],amplitude [um],amplitude_y [um]", "has no phase column of probe x beside it; add 'phase [deg]'"),
    ("amplitude [um],phase [deg],time [s]", "no speed column; add 'speed [rpm]'"),
])
def test_bad_headers(tmp_path, head, says):
    refused(vectors(csv(tmp_path, table(), head=head)), says)


def test_a_speed_that_is_not_positive(tmp_path):
    refused(vectors(csv(tmp_path, table(speeds=[0] + SPEEDS[1:]))), "line 2, column 'speed [rpm]': a speed must be "
            "positive")


def test_a_speed_unit_that_contradicts_the_header(tmp_path):
    refused(vectors(csv(tmp_path, table()), speed_unit="Hz"), "'speed [rpm]' is in rpm, speed_unit says Hz")


@pytest.mark.parametrize("slow_roll, says", [
    ((10 * RPM, 900 * RPM), "between 10 rpm and 900 rpm (1.0472 to 94.2478 rad/s); its speeds run from 1000 rpm"),
    ((200.0, 100.0), "slow_roll: (200, 100) rad/s is no speed range: 0 <= low < high"),
    ("slow", "slow_roll: 'slow' is no speed range: give (low, high) in rad/s"),
])
def test_bad_slow_roll_ranges(tmp_path, slow_roll, says):
    refused(vectors(csv(tmp_path, table()), slow_roll=slow_roll), says)


# ---- raw signals ----------------------------------------------------------------------------------------------

def short(path, **kw):
    """A 3-s raw run-up from 50 to 125 rad/s sampled at 2 kHz (30 whole revolutions)."""
    return write_signals(path, t_end=3.0, fs=2000.0, **kw)


def test_no_key_phasor_and_no_speed_channel(tmp_path):
    refused(lambda: read_signals(short(tmp_path / "s.csv", keyphasor=None)),
            "s.csv: no key-phasor and no speed channel: add 'keyphasor [V]'")


def test_a_few_missed_pulses_are_dropped_and_noted(tmp_path):
    one = read_signals(short(tmp_path / "s.csv", missing=(12,)))
    assert "1 revolution(s) with a missed pulse dropped" in one.notes[0]
    # the two revolutions around the missed pulse read as one of twice the period, dropped
    assert len(one.speed) == len(read_signals(short(tmp_path / "t.csv")).speed) - 2


def test_too_many_missed_pulses(tmp_path):
    refused(lambda: read_signals(short(tmp_path / "s.csv", missing=tuple(range(3, 30, 4)))),
            "column 'keyphasor [V]'", "miss a pulse (more than 10%): the key-phasor is unreliable")


def test_a_spurious_pulse(tmp_path):
    refused(lambda: read_signals(short(tmp_path / "s.csv", extra=(15,))), "column 'keyphasor [V]'",
            "a spurious pulse")


def test_two_marks_on_the_shaft_against_the_speed_channel(tmp_path):
    """A pulse at every half turn halves every revolution alike: only the speed channel can tell."""
    refused(lambda: read_signals(short(tmp_path / "s.csv", extra=tuple(range(40)), speed=True)),
            "the key-phasor gives 2 times the speed of column 'speed [rpm]'")


def test_a_key_phasor_high_half_a_turn_is_read_at_its_rising_edge_and_the_notes_say_so(tmp_path):
    one = read_signals(short(tmp_path / "s.csv", width=math.pi))
    assert "high 50% of the time: neither state is a short pulse, its rising edge taken" in one.notes[0]


def test_a_missing_file_and_a_text_that_is_no_table(tmp_path):
    refused(vectors(tmp_path / "none.csv"), "none.csv: no such data file")
    (tmp_path / "notes.csv").write_text("run-up of 3 May\nall fine\n")
    refused(vectors(tmp_path / "notes.csv"), "not a data table", "e.g. 'speed [rpm],amplitude [um],phase [deg]'")
    (tmp_path / "head.csv").write_text(HEAD + "\n")
    refused(vectors(tmp_path / "head.csv"), "head.csv: no data rows")


def test_a_constant_key_phasor(tmp_path):
    f = tmp_path / "s.csv"
    f.write_text("time [s],probe_x [um],keyphasor [V]\n" + "\n".join(f"{k / 1000},{math.sin(k / 10)},0"
                                                                      for k in range(2000)) + "\n")
    refused(lambda: read_signals(f), "column 'keyphasor [V]' is constant (0): no pulses")


def test_too_few_samples_per_revolution(tmp_path):
    refused(lambda: read_signals(write_signals(tmp_path / "s.csv", t_end=3.0, fs=100.0, keyphasor=None,
                                               speed=True)),
            "column 'time [s]'", "sample(s); order tracking needs at least 8 per revolution: sample faster")


def _speed_record(path, speed):
    t = np.arange(0, 6, 1 / 2000)
    w = speed(t)
    phi = np.concatenate(([0], np.cumsum(0.5 * (w[1:] + w[:-1]) / 2000)))
    np.savetxt(path, np.column_stack((t, 10 * np.cos(phi), w)), delimiter=",", comments="",
               header="time [s],probe_x [um],speed [rad/s]")
    return path


def test_a_raw_run_up_that_turns_into_a_coast_down(tmp_path):
    f = _speed_record(tmp_path / "s.csv", lambda t: 100 + 40 * np.minimum(t, 3) - 40 * np.maximum(t - 3, 0))
    refused(lambda: read_signals(f), "s.csv: at t = ", "the speed turns from", "a run-up and a coast-down in one "
            "record")


def test_a_negative_speed_channel(tmp_path):
    f = _speed_record(tmp_path / "s.csv", lambda t: 100 - 40 * t)
    refused(lambda: read_signals(f), "column 'speed [rad/s]': a speed must not be negative")


@pytest.mark.parametrize("edit, says", [
    (lambda lines: lines[:100] + ["0.0495,nan,nan,0"] + lines[101:], "line 101, column 'probe_x [um]': 'nan' is not "
     "a finite number"),
    (lambda lines: lines[:100] + [lines[99]] + lines[101:], "line 101, column 'time [s]': the time does not rise"),
    (lambda lines: [lines[0].replace("probe_x [um]", "probe_x [V]")] + lines[1:], "column 'probe_x [V]': 'V' is "
     "not a length unit"),
    (lambda lines: [lines[0].replace("keyphasor [V]", "keyphasor [A]")] + lines[1:], "'A' is not a unit of a "
     "key-phasor: write V, mV or 1"),
])
def test_bad_raw_samples(tmp_path, edit, says):
    f = short(tmp_path / "s.csv")
    f.write_text("\n".join(edit(f.read_text().splitlines())) + "\n")
    refused(lambda: read_signals(f), says)


def test_a_raw_file_read_as_vectors_and_vectors_read_as_signals(tmp_path):
    refused(vectors(short(tmp_path / "s.csv")), "unknown quantity 'probe_x'")
    refused(lambda: read_signals(csv(tmp_path, table())), "unknown quantity 'amplitude'")
