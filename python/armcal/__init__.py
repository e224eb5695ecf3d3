"""armcal, the robot calibrator, for notebooks.

Load a robot model, identify or diagnose its errors from measurements (files or
numpy arrays), read the report as Python objects, predict and compensate with
numpy arrays in and out, read and write calibration files. Lengths and angles
in and out are in the model's units, as in the files of docs/file-formats.md.

    import armcal
    model = armcal.load_model("puma560")
    data, truth = armcal.simulate(model, poses=100, seed=1)
    result = armcal.identify(model, data)
    q_corrected = result.calibration.compensate(data.q)

Errors are exceptions carrying the command line's messages: a refused input
is `InputError` (file:line:column: message; for arrays "data row 17: ..."
with the row as numpy indexes it), any other failure `ArmcalError`.
"""

from ._native import (
    ArmcalError,
    Calibration,
    Diagnosis,
    Identification,
    InputError,
    Measurements,
    Model,
    Outcome,
    builtin_data,
    builtin_models,
    diagnose,
    holdout,
    identify,
    load_calibration,
    load_measurements,
    load_model,
    measurements,
    parse_measurements,
    parse_model,
    plan,
    simulate,
)

__all__ = [
    "ArmcalError",
    "Calibration",
    "Diagnosis",
    "Identification",
    "InputError",
    "Measurements",
    "Model",
    "Outcome",
    "builtin_data",
    "builtin_models",
    "diagnose",
    "holdout",
    "identify",
    "load_calibration",
    "load_measurements",
    "load_model",
    "measurements",
    "parse_measurements",
    "parse_model",
    "plan",
    "simulate",
]
