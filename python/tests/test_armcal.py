"""The Python package against the library it binds: models, data from files
and from numpy arrays, the reports of identify and diagnose, predict and
compensate with numpy arrays, calibration files, and the errors."""

import warnings
from pathlib import Path

import numpy as np
import pytest

import armcal

ROOT = Path(__file__).resolve().parents[2]
UR10E_CAMERA = "figaroh-ur10e-camera"
UR10E_MODEL = ROOT / "models" / f"{UR10E_CAMERA}.toml"
UR10E_DATA = ROOT / "data" / UR10E_CAMERA / "measurements.csv"

# The compensation's convergence tolerance on the position residual, m
# (armcal_shared::compensation::Limits::tolerance in f64).
COMPENSATION_TOLERANCE_M = 1e-9
METRES_PER_UNIT = {"m": 1.0, "mm": 1e-3, "in": 0.0254}


def csv_columns(path):
    """The columns of a measurement CSV, by header name, read by numpy."""
    lines = [line for line in Path(path).read_text().splitlines() if line and not line.startswith("#")]
    names = lines[0].split(",")
    table = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    return {name: table[:, i] for i, name in enumerate(names)}


@pytest.fixture(scope="module")
def puma():
    return armcal.load_model("puma560")


@pytest.fixture(scope="module")
def puma_session(puma):
    """A simulated PUMA session: 80 positions, ±1 mm / ±1 mrad errors, 20 µm noise."""
    return armcal.simulate(puma, poses=80, seed=7)


@pytest.fixture(scope="module")
def puma_fit(puma, puma_session):
    return armcal.identify(puma, puma_session[0])


def test_a_builtin_model_loads_by_name_with_its_units(puma):
    assert puma.name == "puma560"
    assert puma.dof == 6
    assert (puma.length_unit, puma.angle_unit) == ("in", "rad")
    assert puma.joint_types == ["revolute"] * 6
    assert puma.source == "built-in puma560"
    assert "puma560" in armcal.builtin_models()


def test_a_toml_model_file_loads_from_its_path():
    model = armcal.load_model(str(UR10E_MODEL))
    assert model.source == str(UR10E_MODEL)
    assert model.dof == 6
    assert model.length_unit == "m"
    text_model = armcal.parse_model(UR10E_MODEL.read_text(), file="ur10e.toml")
    assert text_model.source == "ur10e.toml"
    q = np.zeros(6)
    np.testing.assert_array_equal(model.forward(q), text_model.forward(q))


def test_identify_from_a_file_equals_identify_from_the_builtin_data_set():
    model = armcal.load_model(str(UR10E_MODEL))
    from_file = armcal.identify(model, str(UR10E_DATA))
    from_name = armcal.identify(armcal.load_model(UR10E_CAMERA), UR10E_CAMERA)
    assert from_file.report["parameters"] == from_name.report["parameters"]
    assert from_file.calibration.to_bytes() == from_name.calibration.to_bytes()


def test_identify_from_numpy_arrays_gives_the_file_routes_result():
    model = armcal.load_model(str(UR10E_MODEL))
    c = csv_columns(UR10E_DATA)
    q = np.column_stack([c[f"q{j}"] for j in range(1, 7)])
    xyz = np.column_stack([c["x"], c["y"], c["z"]])
    quat = np.column_stack([c["qw"], c["qx"], c["qy"], c["qz"]])
    data = armcal.measurements(model, q, xyz, quat=quat)
    assert len(data) == len(q)
    assert data.rows == list(range(len(q)))
    np.testing.assert_array_equal(data.q, q)
    from_arrays = armcal.identify(model, data)
    from_file = armcal.identify(model, armcal.load_measurements(model, str(UR10E_DATA)))
    a, f = from_arrays.report, from_file.report
    assert [p["name"] for p in a["parameters"]] == [p["name"] for p in f["parameters"]]
    assert [p["status"] for p in a["parameters"]] == [p["status"] for p in f["parameters"]]
    np.testing.assert_allclose(
        [p["error"] for p in a["parameters"]],
        [p["error"] for p in f["parameters"]],
        rtol=1e-9,
        atol=1e-12,
    )
    assert from_arrays.position_rms == pytest.approx(from_file.position_rms, rel=1e-9)


def test_the_identify_report_has_the_fields_of_interface_md(puma_fit):
    report = puma_fit.report
    assert report["params"] == "full"
    assert isinstance(report["iterations"], int)
    assert report["converged"] is True
    assert report["condition_number"] > 0
    assert set(report["residual"]) >= {"position_rms", "orientation_rms"}
    assert report["residual"]["position_rms"] == pytest.approx(puma_fit.position_rms)
    names = [p["name"] for p in report["parameters"]]
    assert {"theta1", "s2", "a2", "alpha3", "base.x", "tool.z"} <= set(names)
    for p in report["parameters"]:
        assert set(p) >= {"name", "nominal", "error", "std", "status"}
        if p["status"] == "identified":
            assert p["std"] > 0
        else:
            assert p["status"] == "fixed"
            assert p["std"] is None and p["reason"]
    # The typed accessors agree with the report.
    assert puma_fit.converged is True
    identified = {p["name"]: p["error"] for p in report["parameters"] if p["status"] == "identified"}
    assert puma_fit.errors == identified


def test_diagnose_names_a_hidden_joint_compliance_and_reports_interface_fields(puma):
    data, _ = armcal.simulate(puma, poses=120, seed=3, effects=["joint_compliance:2"])
    diagnosis = armcal.diagnose(puma, data, folds=5)
    report = diagnosis.report
    assert report["noise_estimate_mm"] > 0
    holdout = report["holdout"]
    assert holdout["method"] == "5-fold"
    assert holdout["extended_rms_mm"] <= holdout["geometric_rms_mm"] <= holdout["nominal_rms_mm"]
    assert [e["name"] for e in report["effects"]] == ["joint_compliance"]
    assert report["effects"][0]["joints"] == [2]
    assert report["effects"][0]["gain"] > 1
    # Rows of arrays are numbered from 0, as numpy indexes them.
    assert all(0 <= r < len(data) for r in report["outlier_rows"])
    assert diagnosis.calibration.effects == ["joint_compliance"]
    # The expected held-out errors, model units: the calibration's with its
    # effect, and its geometry refitted without it (what a URDF holds).
    cal = diagnosis.calibration
    mm = {"m": 1e3, "mm": 1.0, "in": 25.4}[cal.length_unit]
    assert abs(cal.held_out * mm - holdout["extended_rms_mm"]) <= 1e-9 * holdout["extended_rms_mm"]
    geometric = cal.geometric
    assert geometric.effects == [] and geometric.geometric is None
    assert abs(geometric.held_out * mm - holdout["geometric_rms_mm"]) <= 1e-9 * holdout["geometric_rms_mm"]
    assert "joint_compliance" in diagnosis.summary
    assert diagnosis.html.lstrip().lower().startswith("<!doctype html")


def test_predict_and_compensate_take_and_return_numpy_arrays(puma, puma_fit, puma_session):
    data, _ = puma_session
    cal = puma_fit.calibration
    q = data.q[:20]
    assert cal.predict(q).shape == (20, 3)
    assert cal.compensate(q).shape == (20, 6)
    assert cal.predict(q[0]).shape == (3,)
    assert cal.compensate(q[0]).shape == (6,)
    assert cal.compensate(q.tolist()).shape == (20, 6)
    assert puma.forward(q, orientation=True).shape == (20, 7)


def test_the_calibrated_model_predicts_the_measurements(puma_fit, puma_session):
    data, _ = puma_session
    residual = puma_fit.calibration.predict(data.q) - data.xyz
    rms = np.sqrt(np.mean(np.sum(residual**2, axis=1)))
    assert rms == pytest.approx(puma_fit.position_rms, rel=1e-6)


def test_compensated_commands_take_the_calibrated_robot_to_the_nominal_pose(puma, puma_fit, puma_session):
    data, _ = puma_session
    cal = puma_fit.calibration
    q = data.q[:30]
    with warnings.catch_warnings():
        # No row may be bounded or unconverged. Rows near the wrist singularity
        # (q5 within 0.01 rad of π here) reach their point with the flange
        # turned, and are named: expected.
        warnings.simplefilter("ignore")
        warnings.filterwarnings("error", message=".*(bounded|converge).*")
        corrected = cal.compensate(q)
    with warnings.catch_warnings():
        # The corrected commands of poses at the edge of the session's joint
        # ranges lie beyond them by the correction (milliradians): warned,
        # and expected here.
        warnings.simplefilter("ignore")
        reached = cal.predict(corrected)
    intended = puma.forward(q)
    tolerance = 10 * COMPENSATION_TOLERANCE_M / METRES_PER_UNIT[puma.length_unit]
    assert np.max(np.linalg.norm(reached - intended, axis=1)) < tolerance
    # The corrections are real: the uncorrected commands miss by the calibration's errors.
    assert np.max(np.linalg.norm(cal.predict(q) - intended, axis=1)) > 1000 * tolerance


def test_rows_outside_the_identified_ranges_warn_once_each(puma_fit, puma_session):
    """The calibration was identified on the session's joint ranges at 20–30 °C:
    a row with q2 0.5 rad beyond its largest value and a row at 140 °C are
    predicted all the same, and named in one UserWarning each, with the worst
    excess in the model's units (rad) and the row as numpy counts it."""
    data, _ = puma_session
    cal = puma_fit.calibration
    q = np.array(data.q[:3])
    q[1, 1] = np.max(data.q[:, 1]) + 0.5
    with pytest.warns(UserWarning) as caught:
        predicted = cal.predict(q, temp=[25.0, 25.0, 140.0])
    assert predicted.shape == (3, 3)
    messages = [str(w.message) for w in caught]
    assert len(messages) == 2, messages
    assert messages[0].startswith("joints: q2 outside the range the calibration was identified on")
    assert "on 1 of 3 rows, at worst 0.5 rad beyond (row 1)" in messages[0]
    assert messages[1].startswith("joints: temp outside")
    assert "(20 to 30 °C) on 1 of 3 rows, at worst 110 °C beyond (row 2)" in messages[1]


def test_a_fit_that_did_not_converge_is_returned_but_not_written(puma, puma_session, tmp_path):
    """As `armcal identify` exits 1 without `--write-failed`: the result is
    there to inspect (`converged`, `failure`, the residuals), and writing its
    calibration raises ArmcalError with the reason unless write_failed=True."""
    fit = armcal.identify(puma, puma_session[0], prior_length=1e-300, prior_angle=1e-300)
    assert fit.converged is False
    assert "did not converge after" in fit.failure
    assert "nominal" in fit.failure
    cal = fit.calibration
    assert cal.failure == fit.failure
    path = tmp_path / "failed.cal"
    with pytest.raises(armcal.ArmcalError, match="write_failed=True writes it anyway") as e:
        cal.write(str(path))
    assert not isinstance(e.value, armcal.InputError)
    assert not path.exists()
    with pytest.raises(armcal.ArmcalError, match="did not converge"):
        cal.to_bytes()
    cal.write(str(path), write_failed=True)
    assert path.read_bytes() == cal.to_bytes(write_failed=True)


def test_a_converged_fit_has_no_failure(puma_fit):
    assert puma_fit.failure is None and puma_fit.calibration.failure is None


def test_a_calibration_written_to_a_file_reads_back_with_equal_bytes(puma_fit, tmp_path):
    cal = puma_fit.calibration
    path = tmp_path / "puma.cal"
    cal.write(str(path))
    assert path.read_bytes() == cal.to_bytes()
    back = armcal.load_calibration(str(path))
    assert back.to_bytes() == cal.to_bytes()
    assert back == cal
    assert armcal.Calibration.from_bytes(bytes(cal)) == cal
    assert back.errors == cal.errors and back.targets == "world"


def test_a_bad_model_file_raises_with_file_line_and_column(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "bad"\nconvention = "dh"\nlength_unit = "furlong"\n')
    with pytest.raises(armcal.InputError) as caught:
        armcal.load_model(str(path))
    e = caught.value
    assert str(e).startswith(f"{path}:3:")
    assert "furlong" in str(e)
    assert (e.file, e.line) == (str(path), 3) and e.column > 0
    assert isinstance(e, armcal.ArmcalError)


def test_a_missing_file_raises_naming_it():
    with pytest.raises(armcal.InputError, match="no-such-model.toml"):
        armcal.load_model("no-such-model.toml")


def test_a_nan_in_an_array_raises_naming_its_row_and_column(puma, puma_session):
    data, _ = puma_session
    q = data.q.copy()
    q[17, 2] = np.nan
    with pytest.raises(armcal.InputError) as caught:
        armcal.measurements(puma, q, data.xyz)
    assert str(caught.value) == "data row 17: column 'q3': NaN is not a finite number"
    assert caught.value.row == 17
    cal = armcal.identify(puma, data).calibration
    with pytest.raises(armcal.InputError, match=r"^joints row 17: column 'q3': NaN"):
        cal.predict(q)
    with pytest.raises(armcal.InputError, match=r"^joints row 17: column 'q3': NaN"):
        cal.compensate(q)


def test_arrays_of_the_wrong_shape_are_refused_naming_the_array(puma, puma_session):
    data, _ = puma_session
    with pytest.raises(armcal.InputError, match=r"'q' has shape \(80, 5\), expected \(80, 6\)"):
        armcal.measurements(puma, data.q[:, :5], data.xyz)
    with pytest.raises(armcal.InputError, match=r"'xyz' has shape \(79, 3\)"):
        armcal.measurements(puma, data.q, data.xyz[:79])


def test_data_read_against_another_model_is_refused(puma_session):
    with pytest.raises(armcal.InputError, match="read against the model"):
        armcal.identify(armcal.load_model("ur5e"), puma_session[0])


def test_simulate_repeats_with_its_seed(puma):
    a, truth_a = armcal.simulate(puma, poses=10, seed=5)
    b, truth_b = armcal.simulate(puma, poses=10, seed=5)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.xyz, b.xyz)
    assert truth_a == truth_b
    assert a.temp is not None and a.quat is None


def test_the_papers_model_needs_full_poses_and_stated_scales_must_be_positive(puma, puma_session):
    full_poses, _ = armcal.simulate(puma, poses=60, seed=2, orientation_noise=1e-5)
    assert full_poses.quat.shape == (60, 4)
    assert armcal.identify(puma, full_poses, params="paper").report["params"] == "paper"
    with pytest.raises(armcal.InputError, match="needs full poses"):
        armcal.identify(puma, puma_session[0], params="paper")
    with pytest.raises(armcal.InputError, match="position_noise: -1"):
        armcal.identify(puma, puma_session[0], position_noise=-1.0)


MUKCA = ROOT / "data" / "mukca-ball-socket"


def test_a_session_without_a_tracker_identifies_as_the_command_line():
    """MUKCA's panda_6 `front` placement: a ball on the flange seated in two
    sockets 50 mm apart, no coordinate measured. Its rows name their socket
    (xyz NaN); identify gives what

        armcal identify --model data/mukca-ball-socket/original/urdf/panda.urdf \\
          --tip-link ball_link --data data/mukca-ball-socket/panda_6/front.csv --json r.json

    writes (its figures below, as written), with the contacts' noise
    estimated, the distance's stated and the prior's scale chosen by the
    rows' cross-validation (×10); the calibration puts each socket's
    rows about its fitted point; diagnose chooses the model the command line
    chooses (`armcal diagnose` on the same files: every D-H parameter at ten
    times the stated prior, no effect, no blunder) with its held-out figures."""
    model = armcal.load_model(str(MUKCA / "original" / "urdf" / "panda.urdf"), tip_link="ball_link")
    data = armcal.load_measurements(model, str(MUKCA / "panda_6" / "front.csv"))
    assert data.is_constrained
    assert {c for c in data.contacts} == {("point", "front.0"), ("point", "front.1")}
    assert data.distances == [("front.0", "front.1", 0.05, 5e-05)]
    assert np.isnan(data.xyz).all()

    result = armcal.identify(model, data)
    report = result.report
    assert report["residual"]["position_rms_mm"] == pytest.approx(0.1943856698480506, rel=1e-12)
    assert report["noise"] == [
        {
            "channel": "point contact",
            "used": pytest.approx(0.00012236266355448796, rel=1e-12),
            "shown_by_residuals": pytest.approx(0.0001223851727753088, rel=1e-12),
            "source": "estimated",
            "unit": "m",
        },
        {"channel": "distance", "used": 5e-05, "shown_by_residuals": 5e-05, "source": "stated", "unit": "m"},
    ]
    # Each fitted socket is the mean of its rows' calibrated ball centres,
    # pulled by the one distance within its standard error; at the optimum
    # the distance row pulls the two sockets by equal and opposite amounts
    # (31 rows of one weight each: n w² (P − mean) = ∓λ u).
    predicted = result.calibration.predict(data.q)[:, :3]
    pulls = []
    for point in report["points"]:
        rows = [i for i, c in enumerate(data.contacts) if c == ("point", point["name"])]
        assert len(rows) == 31
        pull = np.array(point["xyz"]) - predicted[rows].mean(axis=0)
        assert np.all(np.abs(pull) < 3 * np.array(point["std"])), point["name"]
        pulls.append(pull)
    np.testing.assert_allclose(pulls[0], -pulls[1], rtol=0, atol=1e-9)

    assert report["prior"]["factor"] == 10.0 and report["prior"]["chosen_by"] == "cross-validation"
    diagnosis = armcal.diagnose(model, data).report
    assert diagnosis["chosen"]["label"] == "full, prior ×10"
    # identify's cross-validation of every parameter at ×10 is diagnose's of the model it chose.
    assert report["prior"]["held_out"][-1]["rms_mm"] == pytest.approx(
        diagnosis["holdout"]["extended_rms_mm"], rel=1e-9
    )
    assert diagnosis["effects"] == [] and diagnosis["outlier_rows"] == []
    assert diagnosis["noise"][0]["channel"] == "point contact"
    holdout = diagnosis["holdout"]
    assert holdout["nominal_rms_mm"] == pytest.approx(9.784269027398766, rel=1e-12)
    assert holdout["extended_rms_mm"] == pytest.approx(0.23133917884507466, rel=1e-12)


def test_sessions_without_a_tracker_are_held_out_as_the_command_line():
    """MUKCA's panda_6: each plate placement left out in turn, the arm
    calibrated on the other two with the prior's scale chosen by their rows'
    cross-validation, and the placement left out predicted by the nominal
    URDF, MUKCA's calibrated URDF and the calibration, as

        armcal holdout --model data/mukca-ball-socket/original/urdf/panda.urdf --tip-link ball_link \\
          --reference data/mukca-ball-socket/original/calibrated_urdf/panda_6/panda_calibrated.urdf \\
          --data data/mukca-ball-socket/panda_6/{front,left,right}.csv

    prints (mm, to its three decimals: the spread of the predicted ball centres
    at each socket, RMS over the sockets, and the predicted socket distance
    less 50 mm). Here in m, the URDF's unit, to the printed rounding."""
    urdf = MUKCA / "original" / "urdf" / "panda.urdf"
    model = armcal.load_model(str(urdf), tip_link="ball_link")
    mukca = armcal.load_model(
        str(MUKCA / "original" / "calibrated_urdf" / "panda_6" / "panda_calibrated.urdf"), tip_link="ball_link"
    )
    sessions = [str(MUKCA / "panda_6" / f"{p}.csv") for p in ("front", "left", "right")]
    rows = armcal.holdout(model, sessions, reference=mukca, select="prior")
    printed = {  # placement: nominal, MUKCA, armcal; each (spread, distance error) in mm
        "front": ((9.609, 6.885), (0.197, -0.003), (0.239, -0.085)),
        "left": ((10.958, 3.532), (0.248, 0.195), (0.232, 0.146)),
        "right": ((11.255, 8.210), (0.318, 0.071), (0.282, -0.066)),
    }
    assert [r["file"].endswith(f"{p}.csv") for r, p in zip(rows, printed)] == [True] * 3
    for row, figures in zip(rows, printed.values()):
        assert row["choice"] == "prior ×10"
        for key, (spread, distance) in zip(("nominal", "reference", "calibrated"), figures):
            assert row[key]["spread"] == pytest.approx(spread / 1000, abs=5e-7), key
            assert row[key]["distance_error"] == pytest.approx(distance / 1000, abs=5e-7), key
        sockets = row["calibrated"]["points"]
        assert len(sockets) == 2 and len(row["calibrated"]["distances"]) == 1
        # The spread is the RMS of the two sockets' own.
        rms = np.sqrt(np.mean([p["spread"] ** 2 for p in sockets]))
        assert row["calibrated"]["spread"] == pytest.approx(rms, rel=1e-12)
    # Trained once on `front` (MUKCA's own training placement), predicting the others.
    once = armcal.holdout(model, sessions[1:], train=[sessions[0]])
    assert [r["calibrated"]["spread"] < r["nominal"]["spread"] / 10 for r in once] == [True, True]
    with pytest.raises(armcal.InputError, match="two or more sessions"):
        armcal.holdout(model, sessions[:1])
    with pytest.raises(armcal.InputError, match="select"):
        armcal.holdout(model, sessions, select="best")
    # A session held out and trained on at once is refused, as on the command line.
    with pytest.raises(armcal.InputError, match=r"the same session as .*front\.csv \(the same file\)"):
        armcal.holdout(model, [sessions[0], sessions[0]])
    with pytest.raises(armcal.InputError, match="the same session as"):
        armcal.holdout(model, sessions[1:], train=[armcal.load_measurements(model, sessions[1])])


def test_a_working_tool_replaces_the_measured_ball_as_the_command_line():
    """MUKCA's panda_6 calibrated with its ball, used with the hand's TCP:

        armcal compensate --calibration CAL --joints left.csv \\
          --tool-link panda_hand_tcp --model data/mukca-ball-socket/original/urdf/panda.urdf

    `with_tool_link` gives the calibration that command uses (the ball's
    identified offset left out, the held-out figure of the ball gone),
    `with_tool` the same tool as a frame in the flange frame (the tip link's,
    `ball_link`: the hand's TCP is the URDF's `ball_joint` reversed); its
    commands do not depend on where the ball was nominally mounted."""
    urdf = str(MUKCA / "original" / "urdf" / "panda.urdf")
    model = armcal.load_model(urdf, tip_link="ball_link")
    data = armcal.load_measurements(model, str(MUKCA / "panda_6" / "front.csv"))
    ball = armcal.identify(model, data).calibration
    hand = ball.with_tool_link(urdf, "panda_hand_tcp")
    assert ball.tool_note is None
    assert "tool.x, tool.y, tool.z" in hand.tool_note and "is not applied" in hand.tool_note
    assert not any(name.startswith("tool.") for name in hand.errors)
    assert hand.held_out is None
    q = armcal.load_measurements(model, str(MUKCA / "panda_6" / "left.csv")).q
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # rows outside the identified ranges
        by_link = hand.compensate(q)
        hand_in_ball = [-7.773732033005863e-05, 4.214022515884392e-05, -0.030128297908475325]
        by_frame = ball.with_tool(hand_in_ball).compensate(q)
        moved = armcal.load_model(urdf, tip_link="ball_link", tip_point=[0.008, -0.006, 0.004])
        moved_ball = armcal.identify(moved, armcal.load_measurements(moved, str(MUKCA / "panda_6" / "front.csv")))
        from_moved = moved_ball.calibration.with_tool_link(urdf, "panda_hand_tcp").compensate(q)
    np.testing.assert_allclose(by_link, by_frame, rtol=0, atol=1e-9)
    np.testing.assert_allclose(by_link, from_moved, rtol=0, atol=1e-9)
    with pytest.raises(armcal.InputError, match="tool_link: panda_link5 of .* hangs on 5 moving joints"):
        ball.with_tool_link(urdf, "panda_link5")
    with pytest.raises(armcal.InputError, match="xyz"):
        ball.with_tool([0.0, float("nan"), 0.1])


def test_measured_torques_drive_the_compliance_as_the_command_line():
    """A UR10e reporting its joint torques (`simulate(..., torque_noise=)`,
    the `tau` columns of a measurement file): `tau` gives them back, and
    diagnose fits the arm's masses to them, says so first in its summary,
    and names the compliance of joint 2."""
    model = armcal.load_model("ur10e")
    data, truth = armcal.simulate(model, poses=120, seed=31, effects=["joint_compliance:2:2e-6"], torque_noise=0.05)
    assert data.tau.shape == (120, 6)
    result = armcal.diagnose(model, data)
    assert result.summary.startswith(
        "gravity torques from the measured joint torques (tau1..tau6, 120 poses, tau read as the drives' torques ("
    )
    effect = [e for e in result.report["effects"] if e["name"] == "joint_compliance"]
    assert effect and effect[0]["joints"] == [2]


def test_load_torques_read_as_the_command_line_reads_them():
    """A robot that reports its sensors' load torques (`simulate(...,
    torque_sign="load")`: the drives' negated): identify reads the sign from
    the data, or as `torque_sign` states it, and writes the calibration the
    drives' torques give, byte for byte; a sign that is neither is refused."""
    model = armcal.load_model("ur10e")
    drive, _ = armcal.simulate(model, poses=60, seed=5, torque_noise=0.05)
    load, _ = armcal.simulate(model, poses=60, seed=5, torque_noise=0.05, torque_sign="load")
    np.testing.assert_array_equal(load.tau, -drive.tau)
    want = armcal.identify(model, drive).calibration.to_bytes()
    read = armcal.identify(model, load)
    assert "tau read as the sensors' load torques: negated" in read.summary
    assert read.report["gravity"]["torque_sign"] == "load"
    assert read.calibration.to_bytes() == want
    assert armcal.identify(model, load, torque_sign="load").calibration.to_bytes() == want
    with pytest.raises(armcal.InputError, match="torque_sign"):
        armcal.identify(model, load, torque_sign="sideways")


def test_torques_from_arrays_read_as_from_a_file():
    """`measurements(model, q, xyz, tau=...)` gives the same torques a file's
    `tau1..tauM` would, and a torque that is not a number, or one no arm
    carries, is refused naming its row and column."""
    model = armcal.load_model("ur10e")
    data, _ = armcal.simulate(model, poses=40, seed=3, torque_noise=0.05)
    arrays = armcal.measurements(model, data.q, data.xyz, load=data.load, tau=data.tau)
    np.testing.assert_array_equal(arrays.tau, data.tau)
    bad = data.tau.copy()
    bad[7, 2] = np.nan
    with pytest.raises(armcal.InputError, match="row 7.*tau3"):
        armcal.measurements(model, data.q, data.xyz, tau=bad)
    bad[7, 2] = 3e6
    with pytest.raises(armcal.InputError, match="tau3.*N·mm"):
        armcal.measurements(model, data.q, data.xyz, tau=bad)


def test_every_call_takes_the_model_first():
    """`load_measurements(model, path)` and `parse_measurements(model, text)`
    take the model first, as `identify(model, data)` and `measurements(model,
    q, xyz)` do; the other order is refused saying so, an InputError naming
    the argument `model` as every argument error is (issue 46)."""
    model = armcal.load_model("figaroh-ur10e-camera")
    assert armcal.load_measurements(model, "figaroh-ur10e-camera").q.shape == (23, 6)
    with pytest.raises(armcal.InputError, match=r"^model: load_measurements takes the model first.*load_measurements\(model"):
        armcal.load_measurements("figaroh-ur10e-camera", model)
    with pytest.raises(armcal.InputError, match="^model: parse_measurements takes the model first"):
        armcal.parse_measurements("q1\n", model)


def test_compensation_warnings_come_one_per_kind_with_their_rows():
    """The camera set's calibration (targets in its world frame) bounds most
    rows of its own commands: one UserWarning names them all (how many, the
    first five as the range warnings list rows), and one names the
    registration and `targets="base"`."""
    model = armcal.load_model("figaroh-ur10e-camera")
    data = armcal.load_measurements(model, "figaroh-ur10e-camera")
    cal = armcal.identify(model, data).calibration
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cal.compensate(data.q)
    texts = [str(w.message) for w in caught]
    bounded = [t for t in texts if "correction bounded" in t]
    assert len(bounded) == 1 and " of 23 rows (rows 0, 2, 3, 5, 6, …)" in bounded[0], texts
    assert any('targets="base"' in t for t in texts), texts


def test_several_sessions_identify_as_the_command_line(tmp_path):
    """Several sessions of one robot, as `--data A.csv B.csv` reads them: a
    list of Measurements (or of paths), each with its own base frame and
    tool (the tracker moved, the SMR remounted: `simulate(sessions=)`); the
    report gives each session's figures, the first session's the file's, and
    `same_base=True` on a moved tracker is refused as the command line
    refuses it."""
    model = armcal.load_model("ur5e")
    data, truth = armcal.simulate(model, poses=180, seed=9, sessions=3)
    assert len(truth["sessions"]) == 3
    joined = armcal.identify(model, data)
    sessions = joined.report["sessions"]
    assert [s["poses"] for s in sessions] == [60, 60, 60]
    assert [s["written"] for s in sessions] == [True, False, False]
    for s in sessions:
        # 20 µm per axis: 35 µm in 3-D, in each session's own frames.
        assert s["position_rms_mm"] < 0.05
        assert s["position_rms_mm"] <= s["held_out_rms_mm"] < 0.05
    assert "3 sessions, each with its own base frame and tool" in joined.summary
    with pytest.raises(armcal.InputError, match="still misses the measured points"):
        armcal.identify(model, data, same_base=True)
    # The same sessions as files, a list of paths.
    files = []
    for k in range(3):
        path = tmp_path / f"s-{k + 1}.csv"
        rows = [i for i in range(180) if i // 60 == k]
        header = "q1,q2,q3,q4,q5,q6,x,y,z\n"
        path.write_text(header + "".join(
            ",".join(str(v) for v in [*data.q[i], *data.xyz[i]]) + "\n" for i in rows))
        files.append(str(path))
    from_files = armcal.identify(model, files)
    assert [s["file"] for s in from_files.report["sessions"]] == files
    np.testing.assert_allclose(
        [s["position_rms_mm"] for s in from_files.report["sessions"]],
        [s["position_rms_mm"] for s in sessions], rtol=1e-6)


def test_plan_returns_the_poses_and_the_report_as_the_command_line():
    """`plan(model, n)` gives `n` joint configurations (model units, in
    measurement order) within the joint limits and the box asked, and the
    report of `armcal plan --json`: the predicted accuracy beside as many
    random poses', each parameter's standard error, what no plan identifies;
    a box that is no box is refused naming `within`."""
    model = armcal.load_model("ur10e")
    q, report = armcal.plan(model, 24, within=(-2, -2, 0.1, 2, 2, 2), seed=3)
    assert q.shape == (24, 6)
    assert report["poses"] == 24
    assert report["predicted_rms_mm"] < report["random"]["predicted_rms_mm"]
    assert report["predicted_measured_rms_mm"] > report["predicted_rms_mm"]
    assert any(h["name"] == "theta1" for h in report["held"])
    with pytest.raises(armcal.InputError, match="within"):
        armcal.plan(model, 10, within=(1, 1, 1, 0, 0, 0))


def test_plan_for_sockets_and_compliance(tmp_path):
    """`plan(model, n, sockets=path)` plans a session seating a ball in the
    sockets of the file, the poses shared among them evenly and the report
    naming each row's socket; `effects=["compliance"]` gives each joint's
    compliance its predicted standard error."""
    plate = tmp_path / "plate.csv"
    plate.write_text(
        "point,x,y,z\ns0,0.45,-0.15,0.05\ns1,0.45,0.15,0.05\ns2,0.6,0,0.05\n"
        "distance,s0,s1,0.3\n"
    )
    model = armcal.load_model("ur5e")
    q, report = armcal.plan(model, 30, sockets=str(plate), candidates=None)
    assert q.shape == (30, 6)
    assert sorted(report["socket_of"].count(s) for s in ("s0", "s1", "s2")) == [10, 10, 10]
    assert report["predicted_rms_mm"] < report["random"]["predicted_rms_mm"]
    q, report = armcal.plan(armcal.load_model("ur10e"), 30, effects=["compliance"])
    assert {c["joint"] for c in report["compliance"]} >= {2, 3}


def test_ctrl_c_interrupts_a_long_diagnosis_at_once():
    """Ctrl-C (SIGINT) during a diagnosis of 10⁵ positions (over a second)
    raises KeyboardInterrupt within a fraction of a second, as Python does
    for its own long calls; the computation is not waited for."""
    import os
    import signal
    import threading
    import time

    model = armcal.load_model("puma560")
    data, _ = armcal.simulate(model, poses=100_000, seed=2)
    timer = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        armcal.diagnose(model, data)
    elapsed = time.perf_counter() - start
    timer.join()
    assert elapsed < 0.8, elapsed
