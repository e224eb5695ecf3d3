"""The edges of the Python calls (issue 46): every argument refused is an
`armcal.InputError` naming it; arrays by their dtype (float64 as is, float32
widened and held to the identified ranges at float32's resolution, integers
widened, booleans and complex numbers refused); Ctrl-C stops a long `plan`,
`identify` or `diagnose` within a tenth of a second and a step, nothing
running on after it, and interrupts a long `compensate` as fast."""

import re
import signal
import threading
import time
import warnings

import numpy as np
import pytest

import armcal

# Ctrl-C's latency allowed, s: the 0.1 s asked, plus the slowest step of a
# plan between two of its cancellation checks. Measured with SIGINT at 0.02 to
# 3 s into this test's plan, on 2 cores under a load of 6: 86 ms at worst
# (before the exchange: the identifiability check at every candidate), 23–45
# ms in the exchange (a pass over the 10,000 candidates), each with up to the
# 10 ms the main thread polls its signals at.
CTRL_C_LATENCY_S = 0.1 + 0.09
# Ctrl-C's latency allowed for `identify` and `diagnose` of 10⁵ rows, s: the
# 0.1 s asked, plus their slowest step between two cancellation checks (every
# pass over the rows asks at its chunks: the rows sorted into configurations,
# the deleted residuals, the candidates' gravity torques, the linearisation's
# Jacobian zeroed a few columns at a time). Measured with SIGINT at 40 points
# from 1 % to 97 % of each call on 2 cores under a load of 2.5–4.5: 46 ms at
# worst for identify, 79 ms for diagnose (the unwinding of a linearisation
# made for the effects' scores: its rows, configurations and folds), each
# with up to the 10 ms the main thread polls its signals at; 0.14 and 0.17 s
# before these checks.
FIT_CTRL_C_LATENCY_S = 0.1 + 0.08
# CPU time (both cores) a stopped computation may still take after
# KeyboardInterrupt, s: the test's own Python, not a computation's.
CPU_AFTER_STOP_S = 0.02


@pytest.fixture(scope="module")
def puma():
    return armcal.load_model("puma560")


@pytest.fixture(scope="module")
def puma_fit(puma):
    """A simulated PUMA session of 40 positions and its calibration."""
    data, _ = armcal.simulate(puma, poses=40, seed=3)
    return data, armcal.identify(puma, data).calibration


def refused(argument, call):
    """The InputError `call` raises, checked to name `argument` as the
    command line names a flag: `argument: message`, `file` the argument."""
    with pytest.raises(armcal.InputError) as caught:
        call()
    e = caught.value
    assert str(e).startswith(f"{argument}: "), str(e)
    assert e.file == argument and e.line == 0 and e.row is None
    return str(e)


def test_plan_arguments_of_the_wrong_type_are_input_errors_naming_them(puma):
    """A string where the effects' list goes, a negative or fractional count,
    a negative seed, a box that is no list of numbers: InputError naming the
    argument (were TypeError and OverflowError)."""
    assert '["backlash"]' in refused("effects", lambda: armcal.plan(puma, 10, effects="backlash"))
    assert "-1" in refused("poses", lambda: armcal.plan(puma, -1))
    refused("poses", lambda: armcal.plan(puma, 1.5))
    refused("seed", lambda: armcal.plan(puma, 10, seed=-1))
    refused("within", lambda: armcal.plan(puma, 10, within="box"))
    refused("noise", lambda: armcal.plan(puma, 10, noise="fine"))
    refused("orientation", lambda: armcal.plan(puma, 10, orientation="yes"))


def test_fit_and_simulate_arguments_of_the_wrong_type_are_input_errors_naming_them(puma, puma_fit):
    data, _ = puma_fit
    refused("folds", lambda: armcal.diagnose(puma, data, folds=-1))
    refused("position_noise", lambda: armcal.identify(puma, data, position_noise="small"))
    refused("params", lambda: armcal.identify(puma, data, params=3))
    refused("same_base", lambda: armcal.identify(puma, [data], same_base=None))
    refused("poses", lambda: armcal.simulate(puma, poses=-1))
    refused("effects", lambda: armcal.simulate(puma, effects="backlash:2"))
    refused("sessions", lambda: armcal.holdout(puma, "front.csv"))


# Values of the wrong type for any argument: text where a list or a number
# goes, a list where text goes, a negative whole number, None where a value is
# needed, a float where a whole number or a flag goes, a dict.
WRONG = {"text": "oops", "list": [1, 2], "negative": -1, "none": None, "float": 1.5, "dict": {}}


def keyword_probes(puma, data, cal, tmp):
    """Every keyword of every call, each call with arguments it accepts
    (`base`) so that the keyword probed is the one refused."""
    return {
        "load_model": (armcal.load_model, {"name_or_path": "puma560"}, ["name_or_path", "base_link", "tip_link", "tip_point"]),
        "parse_model": (armcal.parse_model, {"text": "x"}, ["text", "file"]),
        "load_measurements": (armcal.load_measurements, {"model": puma, "name_or_path": "x.csv"}, ["model", "name_or_path"]),
        "parse_measurements": (armcal.parse_measurements, {"model": puma, "text": "q1\n"}, ["model", "text", "file"]),
        "measurements": (armcal.measurements, {"model": puma, "q": data.q, "xyz": data.xyz}, ["model", "q", "xyz", "quat", "t", "temp", "load", "tau"]),
        "simulate": (armcal.simulate, {"model": puma, "poses": 10}, ["model", "poses", "seed", "noise", "orientation_noise", "effects", "tilts", "torque_noise", "payloads", "sessions", "torque_sign", "link_errors", "base_errors", "tool_errors", "orientation_bias", "orientation_bias_growth"]),
        "identify": (armcal.identify, {"model": puma, "data": data}, ["model", "data", "params", "position_noise", "orientation_noise", "point_noise", "plane_noise", "prior_length", "prior_angle", "prior_scale", "orientation_weight", "targets", "same_base", "same_tool", "torque_sign"]),
        "diagnose": (armcal.diagnose, {"model": puma, "data": data}, ["model", "data", "folds", "position_noise", "orientation_noise", "point_noise", "plane_noise", "prior_length", "prior_angle", "orientation_weight", "targets", "same_base", "same_tool", "torque_sign"]),
        "holdout": (armcal.holdout, {"model": puma, "sessions": ["a.csv", "b.csv"]}, ["model", "sessions", "train", "reference", "select", "position_noise", "point_noise", "plane_noise", "prior_length", "prior_angle"]),
        "plan": (armcal.plan, {"model": puma, "poses": 5}, ["model", "poses", "orientation", "noise", "orientation_noise", "within", "above", "margin", "candidates", "targets", "effects", "sockets", "seed"]),
        "load_calibration": (armcal.load_calibration, {"path": "x.cal"}, ["path"]),
        "Calibration.read": (armcal.Calibration.read, {"path": "x.cal"}, ["path"]),
        "Calibration.from_bytes": (armcal.Calibration.from_bytes, {"data": b"x"}, ["data"]),
        "Calibration.to_bytes": (cal.to_bytes, {}, ["write_failed"]),
        "Calibration.with_tool": (cal.with_tool, {"xyz": [0, 0, 0.1]}, ["xyz", "rpy"]),
        "Calibration.with_tool_link": (cal.with_tool_link, {"model": "x.urdf", "tool_link": "x"}, ["model", "tool_link", "base_link"]),
        "Calibration.write": (cal.write, {"path": str(tmp / "c.cal")}, ["path", "write_failed"]),
        "Calibration.predict": (cal.predict, {"q": data.q}, ["q", "temp", "load"]),
        "Calibration.compensate": (cal.compensate, {"q": data.q[:2]}, ["q", "temp", "load", "servo"]),
        "Model.forward": (puma.forward, {"q": data.q[:2]}, ["q", "orientation"]),
    }


def test_every_keyword_of_every_call_refuses_a_wrong_type_naming_it(puma, puma_fit, tmp_path, monkeypatch):
    """Each keyword of each call given a value of the wrong type (WRONG) is
    refused with an InputError naming it (a dict, which no keyword takes,
    always), or accepted (None where None is the default, a text where a
    path goes) and refused for what it then means (a file that is not
    there): never Python's own
    TypeError, ValueError or OverflowError, which name no argument (were,
    for paths, texts, flags, points, the model and the reference)."""
    monkeypatch.chdir(tmp_path)
    data, cal = puma_fit
    leaked = []
    for call, (f, base, keywords) in keyword_probes(puma, data, cal, tmp_path).items():
        for keyword in keywords:
            for kind, value in WRONG.items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    try:
                        f(**{**base, keyword: value})
                    except armcal.InputError as e:
                        if e.file == keyword or keyword in str(e):
                            continue
                        # A value of a type the keyword takes (a text for a
                        # path, None for a default) is refused for what it
                        # then means; a dict no keyword takes is refused
                        # naming it.
                        assert kind != "dict", (call, keyword, str(e))
                    except armcal.ArmcalError:
                        pass
                    except Exception as e:
                        leaked.append((call, keyword, kind, f"{type(e).__name__}: {e}"))
    assert not leaked, "\n".join(map(str, leaked))


def test_an_empty_list_of_sessions_is_refused_naming_data(puma):
    """`identify(model, [])` names the argument, not a place `:1:1` in no file."""
    for call in (armcal.identify, armcal.diagnose):
        message = refused("data", lambda: call(puma, []))
        assert "empty list" in message and ":1:1" not in message


def test_float32_joints_at_the_identified_range_raise_no_warning(puma_fit):
    """The session's own joints as float32: the rows at the ends of each
    joint's range round beyond them by up to half a float32 step (1e-7 rad),
    which is not extrapolating: no warning, and the same prediction as their
    float64 values (which are named). A float32 row 0.01 rad beyond is still
    named."""
    data, cal = puma_fit
    q32 = data.q.astype(np.float32)
    assert np.any(q32.astype(np.float64) > data.q.max(axis=0)), "a row rounds beyond its range"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        predicted = cal.predict(q32)
        cal.compensate(q32[:3])
    # The same values given as float64 are held to the exact bounds: named.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        as_float64 = cal.predict(q32.astype(np.float64))
    messages = [str(w.message) for w in caught]
    assert messages and all(re.search(r"outside the range .* at worst 0\.000000\d+ rad beyond", m) for m in messages), messages
    np.testing.assert_array_equal(predicted, as_float64)
    beyond = q32[:2].copy()
    beyond[1, 1] = np.float32(data.q[:, 1].max() + 0.01)
    with pytest.warns(UserWarning, match=r"q2 outside .* on 1 of 2 rows, at worst 0\.01 rad beyond \(row 1\)"):
        cal.predict(beyond)


def test_float32_temperatures_at_the_identified_range_raise_no_warning(puma, puma_fit):
    """A session measured at 20.1 to 30.1 °C (float64) and its temperatures
    given back as float32: 30.1 rounds up to 30.1000004, not named; the same
    values as float64 are."""
    data, _ = puma_fit
    temp = np.linspace(20.1, 30.1, len(data.q))
    session = armcal.measurements(puma, data.q, data.xyz, temp=temp)
    cal = armcal.identify(puma, session).calibration
    temp32 = temp.astype(np.float32)
    assert temp32.astype(np.float64).max() > temp.max()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cal.predict(data.q, temp=temp32)
    with pytest.warns(UserWarning, match=r"temp outside .* \(20\.1 to 30\.1 °C\) on 1 of 40 rows"):
        cal.predict(data.q, temp=temp32.astype(np.float64))


def test_complex_boolean_and_text_arrays_are_refused_naming_the_argument(puma, puma_fit):
    """numpy would drop an imaginary part (with a ComplexWarning) and take
    True for 1.0: both refused, as text and float16 (a thousandth of a
    radian) are, naming the array; integers are widened exactly."""
    data, cal = puma_fit
    q, xyz = data.q, data.xyz
    assert "complex" in refused("q", lambda: armcal.measurements(puma, q + 1e-3j, xyz))
    assert "bool" in refused("q", lambda: armcal.measurements(puma, q > 0, xyz))
    refused("xyz", lambda: armcal.measurements(puma, q, xyz.astype(complex)))
    refused("q", lambda: armcal.measurements(puma, "q", xyz))
    assert "too few digits" in refused("q", lambda: cal.predict(q.astype(np.float16)))
    refused("temp", lambda: armcal.measurements(puma, q, xyz, temp=np.full(len(q), True)))
    refused("q", lambda: cal.predict(q.astype(complex)))
    refused("q", lambda: cal.compensate(q > 0))
    refused("load", lambda: cal.predict(q, load=np.zeros(len(q), dtype=complex)))
    refused("q", lambda: puma.forward(np.zeros(6, dtype=bool)))
    refused("candidates", lambda: armcal.plan(puma, 10, candidates=q > 0))
    whole = np.array([[0, 1, 0, 0, 1, 0]])
    np.testing.assert_array_equal(cal.predict(whole), cal.predict(whole.astype(np.float64)))


def wait_until_idle(window=0.2, most=60.0):
    """Waits until the process spends less than CPU_AFTER_STOP_S of CPU in
    `window` s (at most `most` s): an interrupted `compensate` of an earlier
    test runs on in the background (it has no way to stop) and would hold
    the cores and rayon's threads."""
    deadline = time.perf_counter() + most
    while time.perf_counter() < deadline:
        cpu = time.process_time()
        time.sleep(window)
        if time.process_time() - cpu < CPU_AFTER_STOP_S:
            return
    pytest.fail(f"the process did not go idle within {most} s")


def interrupted_after(seconds, call):
    """Runs `call`, SIGINT sent to the main thread `seconds` into it: the
    time from the signal to KeyboardInterrupt, s, and the CPU time the process
    takes in the 0.3 s after it (what still computes)."""
    sent = []

    def interrupt():
        sent.append(time.perf_counter())
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)

    timer = threading.Timer(seconds, interrupt)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        call()
    latency = time.perf_counter() - sent[0]
    timer.join()
    cpu = time.process_time()
    time.sleep(0.3)
    return latency, time.process_time() - cpu


def test_ctrl_c_interrupts_a_long_compensation_within_a_tenth_of_a_second(puma):
    """`compensate` of 10⁵ rows (4 s) ran with the main thread's signals
    unhandled: SIGINT half a second in now raises KeyboardInterrupt within
    CTRL_C_LATENCY_S (the compensation runs on in the background: it has no
    way to stop yet)."""
    data, _ = armcal.simulate(puma, poses=100_000, seed=2)
    cal = armcal.identify(puma, data).calibration
    latency, _ = interrupted_after(0.5, lambda: cal.compensate(data.q))
    assert latency < CTRL_C_LATENCY_S, latency


@pytest.fixture(scope="module")
def long_session(puma):
    """A simulated PUMA session of 10⁵ tracker positions: identify takes about
    1 s on it, diagnose about 3 s (2 cores)."""
    data, _ = armcal.simulate(puma, poses=100_000, seed=2)
    return data


@pytest.mark.parametrize("call", ["identify", "diagnose"])
def test_ctrl_c_stops_a_long_identify_or_diagnose_within_a_tenth_of_a_second(puma, long_session, call):
    """`identify` and `diagnose` of 10⁵ rows ran on in the background for
    seconds after KeyboardInterrupt: SIGINT at a tenth, three tenths and a
    half of the call's first run (in the fit, the choice of the prior, the
    screen of the rows, the scores of the models and effects; not later: a
    run a third faster than the first would end before the signal) now raises within
    FIT_CTRL_C_LATENCY_S, and the computation has stopped: the process takes no
    more CPU than the test's own (CPU_AFTER_STOP_S in the 0.3 s after)."""
    fit = getattr(armcal, call)
    wait_until_idle()
    start = time.perf_counter()
    fit(puma, long_session)
    whole = time.perf_counter() - start
    for share in (0.1, 0.3, 0.5):
        wait_until_idle()
        latency, cpu = interrupted_after(share * whole, lambda: fit(puma, long_session))
        assert latency < FIT_CTRL_C_LATENCY_S, (share, latency)
        assert cpu < CPU_AFTER_STOP_S, (share, cpu)


def test_ctrl_c_stops_a_long_plan_within_a_tenth_of_a_second():
    """`plan` of 100 full poses of the UR10e among 10,000 candidates (4–6
    s): SIGINT half a second in raises KeyboardInterrupt within
    CTRL_C_LATENCY_S, and the plan has stopped (no CPU spent after it)."""
    model = armcal.load_model("ur10e")
    wait_until_idle()
    latency, cpu = interrupted_after(0.5, lambda: armcal.plan(model, 100, orientation=True))
    assert latency < CTRL_C_LATENCY_S, latency
    assert cpu < CPU_AFTER_STOP_S, cpu
